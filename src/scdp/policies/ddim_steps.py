"""DDIM's deterministic reverse steps (η = 0) with every per-step constant computed once.

The few-step planners run DDIM (the student: 2 steps), and diffusers' ``DDIMScheduler.step`` recomputes
ᾱ, its neighbour, their square roots and a variance that η = 0 multiplies away at every call: at
batch 1 on a CPU that Python costs about a tenth of a student's trajectory
(results/benchmarks/plan_profile_student.md). :class:`DDIMSteps` computes the same quantities once,
by the scheduler's float32 expressions, as :class:`~scdp.policies.ddpm_steps.DDPMSteps` does for DDPM,
and its steps are the scheduler's bit for bit (``tests/test_noise_schedule.py``). It covers the
project's DDIM: ``epsilon`` prediction, η = 0, ᾱ = 1 after the last step (``set_alpha_to_one``),
the x0 estimate clipped to [-1, 1] or not, the timesteps DDPM's ("leading" spacing).
"""

from __future__ import annotations

import torch

from scdp.policies.ddpm_steps import CLIP_RANGE, StepTable
from scdp.policies.noise_schedule import alphas_cumprod, ddpm_timesteps


class DDIMSteps(StepTable):
    """DDIM's reverse steps (η = 0) at ``steps`` inference steps of a training schedule (T timesteps, a
    beta schedule of :data:`scdp.keys.BETA_SCHEDULES`), the x0 estimate clipped or not."""

    def __init__(self, num_train_timesteps: int, beta_schedule: str, clip_sample: bool, steps: int):
        alpha_bar = alphas_cumprod(num_train_timesteps, beta_schedule)
        final = torch.tensor(1.0)  # ᾱ after the last step
        self.timesteps = ddpm_timesteps(num_train_timesteps, steps)  # (steps,) noisiest first
        self.clip = CLIP_RANGE if clip_sample else None
        ratio = num_train_timesteps // steps
        self.table = []
        for t in self.timesteps.tolist():
            alpha_prod_t = alpha_bar[t]
            alpha_prod_t_prev = alpha_bar[t - ratio] if t - ratio >= 0 else final
            beta_prod_t = 1 - alpha_prod_t
            self.table.append((beta_prod_t ** 0.5, alpha_prod_t ** 0.5, alpha_prod_t_prev ** 0.5,
                               (1 - alpha_prod_t_prev) ** 0.5))  # η = 0: the variance term is exactly 0

    def adds_noise(self, i: int) -> bool:
        """Whether step ``i`` adds noise: never (η = 0)."""
        return False

    def step(self, i: int, eps: torch.Tensor, x: torch.Tensor, generator=None, noise: torch.Tensor | None = None,
             table: list | None = None) -> torch.Tensor:
        """x at step ``i`` of :attr:`timesteps` and its predicted noise -> x at the next step (it draws
        nothing: ``generator`` and ``noise`` are accepted for :class:`DDPMSteps`' signature)."""
        sqrt_beta, sqrt_alpha, sqrt_alpha_prev, direction = (table or self.table)[i]
        x0 = (x - sqrt_beta * eps) / sqrt_alpha
        if self.clip is not None:
            x0 = x0.clamp(-self.clip, self.clip)
        return sqrt_alpha_prev * x0 + direction * eps
