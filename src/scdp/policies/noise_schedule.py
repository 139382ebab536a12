"""The training noise schedule (ᾱ_k), DDPM's planning-time timesteps, and the forward noising, as numbers.

These are the quantities diffusers' ``DDPMScheduler`` holds for the project's configuration (its
defaults: β from 1e-4 to 0.02, "leading" timestep spacing, no offset, no zero-SNR rescale), by the
same float32 expressions in the same order, so they are diffusers' bit for bit
(``tests/test_noise_schedule.py`` compares every schedule and step count the configs allow). They
live here rather than in a diffusers object because importing diffusers imports ``torch._dynamo``,
once most of a default ``scdp plan`` (results/benchmarks/responsive.md); DDPM, the paper's sampler
and the default, needs nothing else, nor does DDIM (:mod:`scdp.policies.ddim_steps`). DPM-Solver
stays diffusers' own (:mod:`scdp.policies.schedulers`).

Shapes: T = num_train_timesteps, n = inference steps, B batch.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from scdp.errors import ScdpError
from scdp.keys import BETA_SCHEDULES

BETA_START, BETA_END = 1e-4, 0.02  # the linear schedules' ends (diffusers' defaults)
MAX_BETA = 0.999  # the cosine schedule's cap on a step's β


def _cosine_alpha_bar(t: float) -> float:
    """ᾱ(t) of the cosine schedule (Nichol & Dhariwal 2021, offset s = 0.008), t in [0, 1]."""
    return math.cos((t + 0.008) / 1.008 * math.pi / 2) ** 2


def betas(num_train_timesteps: int, beta_schedule: str) -> torch.Tensor:
    """β_k of the training schedule, (T,) float32."""
    T = num_train_timesteps
    if beta_schedule == "linear":
        return torch.linspace(BETA_START, BETA_END, T, dtype=torch.float32)
    if beta_schedule == "scaled_linear":
        return torch.linspace(BETA_START ** 0.5, BETA_END ** 0.5, T, dtype=torch.float32) ** 2
    if beta_schedule == "squaredcos_cap_v2":
        return torch.tensor([min(1 - _cosine_alpha_bar((i + 1) / T) / _cosine_alpha_bar(i / T), MAX_BETA)
                             for i in range(T)], dtype=torch.float32)
    raise ScdpError("beta_schedule", f"one of {', '.join(BETA_SCHEDULES)}, got {beta_schedule!r}")


def alphas_cumprod(num_train_timesteps: int, beta_schedule: str) -> torch.Tensor:
    """ᾱ_k = ∏_{j<=k} (1 - β_j), (T,) float32."""
    return torch.cumprod(1.0 - betas(num_train_timesteps, beta_schedule), dim=0)


def ddpm_timesteps(num_train_timesteps: int, steps: int) -> torch.Tensor:
    """The n timesteps DDPM denoises through, noisiest first: k·(T // n) for k = n-1 ... 0, (n,) int64."""
    ratio = num_train_timesteps // steps
    return torch.from_numpy((np.arange(0, steps) * ratio).round()[::-1].copy().astype(np.int64))


def add_noise(alpha_bar: torch.Tensor, x0: torch.Tensor, noise: torch.Tensor, k: torch.Tensor) -> torch.Tensor:
    """x_k = √ᾱ_k x0 + √(1-ᾱ_k) ε for a (B, ...) batch at timesteps ``k`` (B,); ``alpha_bar`` (T,) on x0's device."""
    a = alpha_bar.to(dtype=x0.dtype)[k.to(x0.device)]
    scale = (a ** 0.5).flatten().reshape(-1, *[1] * (x0.dim() - 1))
    spread = ((1 - a) ** 0.5).flatten().reshape(-1, *[1] * (x0.dim() - 1))
    return scale * x0 + spread * noise
