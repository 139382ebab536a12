"""DDPM's reverse steps with every per-step constant computed once, so a step is four tensor operations.

diffusers' ``DDPMScheduler.step`` recomputes ten 0-d tensors (ᾱ, their square roots, the posterior
coefficients, the variance) at every call; at batch 1 on a CPU that Python path costs about a
fifth of a cold chunk. :class:`DDPMSteps` takes the same quantities from the scheduler once, by
the same float32 expressions in the same order, and applies them: the result is the scheduler's
bit for bit (``tests/test_warm_start.py`` compares them), with the same noise drawn from the same
generators. Only ``epsilon`` prediction with the fixed-small variance (the project's DDPM) is
covered; the caller falls back to the scheduler otherwise.
"""

from __future__ import annotations

import torch
from diffusers import DDPMScheduler
from diffusers.utils.torch_utils import randn_tensor


class DDPMSteps:
    """The reverse steps of ``scheduler`` at ``steps`` inference steps."""

    def __init__(self, scheduler: DDPMScheduler, steps: int):
        scheduler.set_timesteps(steps)
        self.timesteps = scheduler.timesteps
        self.clip = scheduler.config.clip_sample_range if scheduler.config.clip_sample else None
        self._tables: dict = {}
        self.table = []
        for t in self.timesteps:
            t = int(t)
            prev_t = scheduler.previous_timestep(t)
            alpha_prod_t = scheduler.alphas_cumprod[t]
            alpha_prod_t_prev = scheduler.alphas_cumprod[prev_t] if prev_t >= 0 else scheduler.one
            beta_prod_t, beta_prod_t_prev = 1 - alpha_prod_t, 1 - alpha_prod_t_prev
            current_alpha_t = alpha_prod_t / alpha_prod_t_prev
            current_beta_t = 1 - current_alpha_t
            variance = torch.clamp((1 - alpha_prod_t_prev) / (1 - alpha_prod_t) * current_beta_t, min=1e-20)
            self.table.append((beta_prod_t ** 0.5, alpha_prod_t ** 0.5,
                               (alpha_prod_t_prev ** 0.5 * current_beta_t) / beta_prod_t,
                               current_alpha_t ** 0.5 * beta_prod_t_prev / beta_prod_t,
                               variance ** 0.5 if t > 0 else None))

    @staticmethod
    def supports(scheduler) -> bool:
        config = scheduler.config
        return (isinstance(scheduler, DDPMScheduler) and config.prediction_type == "epsilon"
                and config.variance_type == "fixed_small" and not config.thresholding)

    def adds_noise(self, i: int) -> bool:
        """Whether step ``i`` adds noise (every step but the last, at timestep 0)."""
        return self.table[i][4] is not None

    def on(self, device) -> list:
        """The constants as 0-d tensors on ``device`` (what a CUDA graph reads; the same float32 values)."""
        device = torch.device(device)
        if device not in self._tables:
            self._tables[device] = [tuple(None if c is None else c.to(device) for c in row) for row in self.table]
        return self._tables[device]

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
            noise = randn_tensor(eps.shape, generator=generator, device=eps.device, dtype=eps.dtype)
        return mean + sd * noise
