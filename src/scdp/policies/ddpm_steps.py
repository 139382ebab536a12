"""DDPM's reverse steps with every per-step constant computed once, so a step is four tensor operations.

diffusers' ``DDPMScheduler.step`` recomputes ten 0-d tensors (ᾱ, their square roots, the posterior
coefficients, the variance) at every call; at batch 1 on a CPU that Python path costs about a
fifth of a cold chunk. :class:`DDPMSteps` computes the same quantities once, from the schedule of
:mod:`scdp.policies.noise_schedule`, by the scheduler's float32 expressions in the same order, and
applies them: the result is the scheduler's bit for bit (``tests/test_warm_start.py`` compares
them), with the same noise drawn from the same generators. It covers the project's DDPM:
``epsilon`` prediction, the fixed-small variance, the x0 estimate clipped to [-1, 1] or not.
"""

from __future__ import annotations

import torch

from scdp.policies.noise_schedule import alphas_cumprod, ddpm_timesteps

CLIP_RANGE = 1.0  # clip_sample clips the x0 estimate to [-1, 1] (scaled space)


def randn(shape: tuple, generator=None) -> torch.Tensor:
    """Standard normal draws on the CPU from one generator, or from a list of B (row b from the b-th:
    a scene's draws do not depend on the batch it is in); the draws diffusers' ``randn_tensor`` makes."""
    if isinstance(generator, list) and len(generator) == 1:
        generator = generator[0]
    if isinstance(generator, list):
        return torch.cat([torch.randn((1, *shape[1:]), generator=g) for g in generator], dim=0)
    return torch.randn(shape, generator=generator)


class StepTable:
    """A sampler that scdp steps itself: ``timesteps``, one row of 0-d constants per step in ``table``
    (None where a step has no such term), and ``step(i, eps, x, generator=None, noise=None, table=None)``.
    :class:`DDPMSteps` and :class:`~scdp.policies.ddim_steps.DDIMSteps` are the two."""

    timesteps: torch.Tensor
    table: list

    def on(self, device) -> list:
        """The constants as 0-d tensors on ``device`` (what a CUDA graph reads; the same float32 values)."""
        device = torch.device(device)
        tables = self.__dict__.setdefault("_tables", {})
        if device not in tables:
            tables[device] = [tuple(None if c is None else c.to(device) for c in row) for row in self.table]
        return tables[device]


class DDPMSteps(StepTable):
    """DDPM's reverse steps at ``steps`` inference steps of a training schedule (T timesteps, a beta
    schedule of :data:`scdp.keys.BETA_SCHEDULES`), the x0 estimate clipped or not."""

    def __init__(self, num_train_timesteps: int, beta_schedule: str, clip_sample: bool, steps: int):
        alpha_bar = alphas_cumprod(num_train_timesteps, beta_schedule)
        one = torch.tensor(1.0)
        self.timesteps = ddpm_timesteps(num_train_timesteps, steps)  # (steps,) noisiest first
        self.clip = CLIP_RANGE if clip_sample else None
        self.table = []
        for i, t in enumerate(self.timesteps.tolist()):
            prev_t = int(self.timesteps[i + 1]) if i + 1 < len(self.timesteps) else -1
            alpha_prod_t = alpha_bar[t]
            alpha_prod_t_prev = alpha_bar[prev_t] if prev_t >= 0 else one
            beta_prod_t, beta_prod_t_prev = 1 - alpha_prod_t, 1 - alpha_prod_t_prev
            current_alpha_t = alpha_prod_t / alpha_prod_t_prev
            current_beta_t = 1 - current_alpha_t
            variance = torch.clamp((1 - alpha_prod_t_prev) / (1 - alpha_prod_t) * current_beta_t, min=1e-20)
            self.table.append((beta_prod_t ** 0.5, alpha_prod_t ** 0.5,
                               (alpha_prod_t_prev ** 0.5 * current_beta_t) / beta_prod_t,
                               current_alpha_t ** 0.5 * beta_prod_t_prev / beta_prod_t,
                               variance ** 0.5 if t > 0 else None))

    def adds_noise(self, i: int) -> bool:
        """Whether step ``i`` adds noise (every step but the last, at timestep 0)."""
        return self.table[i][4] is not None

    def step(self, i: int, eps: torch.Tensor, x: torch.Tensor, generator=None, noise: torch.Tensor | None = None,
             table: list | None = None) -> torch.Tensor:
        """x at step ``i`` of :attr:`timesteps` and its predicted noise -> x at the next step. ``noise``:
        this step's noise drawn beforehand (:func:`scdp.policies.sampling.draw_noise`; else drawn here
        from ``generator``); ``table``: the constants on the device (:meth:`on`; default the CPU's)."""
        sqrt_beta, sqrt_alpha, c_x0, c_x, sd = (table or self.table)[i]
        x0 = (x - sqrt_beta * eps) / sqrt_alpha
        if self.clip is not None:
            x0 = x0.clamp(-self.clip, self.clip)
        mean = c_x0 * x0 + c_x * x
        if sd is None:
            return mean
        if noise is None:
            noise = randn(tuple(eps.shape), generator).to(eps.device, eps.dtype)
        return mean + sd * noise
