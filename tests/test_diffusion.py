"""Tests of scdp.policies.diffusion: the diffusion policy's loss (plain and x0-weighted) and its sampler swapped at load time."""

import pytest
import torch
from diffusers import DDPMScheduler

from helpers.tiny import TINY
from scdp.config import PlanningOptions
from scdp.data.windows import WindowData
from scdp.errors import ScdpError
from scdp.policies import loaders
from scdp.policies.base import Observation
from scdp.tasks import NAVIGATION
from scdp.training import parts


def test_diffusion_loss_decreases(tmp_path, small_datasets):
    preset = TINY.with_overrides(["base.train.epochs=10", "base.train.lr=3e-3", "base.train.warmup_steps=5"])
    _, result = parts.train_diffusion(NAVIGATION, small_datasets["navigation"], preset, tmp_path / "b", progress=False)
    assert result.losses[-1] < 0.75 * result.losses[0]


def test_x0_weighted_loss_by_hand(tiny_ckpt, small_datasets, monkeypatch):
    """cap 1 is the plain ε-MSE; cap c weights each window by clip((1 - ᾱ_k) / ᾱ_k, 1, c)."""
    base = loaders.load_diffusion(tiny_ckpt / "base", NAVIGATION)
    data = WindowData(small_datasets["navigation"], base.config.n_obs_steps, base.config.horizon, NAVIGATION)
    batch = data.get(torch.arange(16))
    monkeypatch.setattr(base.unet, "forward", lambda x, k, c, film=None: torch.zeros_like(x))  # ε̂ = 0: loss = noise²
    plain = base.loss(batch, generator=torch.Generator().manual_seed(1))
    weighted = base.loss(batch, generator=torch.Generator().manual_seed(1), x0_weight_cap=10.0)
    g = torch.Generator().manual_seed(1)  # the same draws as loss makes: noise, then steps
    noise = torch.randn(16, base.config.horizon, base.config.state_dim, generator=g)
    k = torch.randint(0, base.config.num_train_timesteps, (16,), generator=g)
    a = DDPMScheduler(num_train_timesteps=base.config.num_train_timesteps, beta_schedule=base.config.beta_schedule).alphas_cumprod[k]
    w = ((1 - a) / a).clamp(1.0, 10.0)
    per = noise.pow(2).mean(dim=(1, 2))
    assert plain == pytest.approx(float(per.mean()), rel=1e-6)
    assert weighted == pytest.approx(float((w * per).sum() / w.sum()), rel=1e-6)
    assert w.max() > 1.0 and weighted != pytest.approx(float(plain))


@pytest.mark.parametrize("sampler,steps", [("ddim", 3), ("dpmsolver", 5), ("ddpm", 7)])
def test_sampler_swapped_at_load_time_runs_its_step_count(tiny_ckpt, monkeypatch, sampler, steps):
    dp = loaders.load_method("dp", tiny_ckpt, NAVIGATION, PlanningOptions(sampler=sampler, steps=steps))
    assert (dp.config.sampler, dp.config.num_inference_steps) == (sampler, steps)
    calls = []
    original = dp.unet.forward
    monkeypatch.setattr(dp.unet, "forward", lambda x, k, c, film=None: calls.append(int(k[0])) or original(x, k, c, film))
    goals = torch.tensor(NAVIGATION.layouts[0], dtype=torch.float32)[None]
    obs = Observation(state_hist=torch.zeros(1, 2, 3), position=torch.zeros(1, 2), goals=goals, target=torch.tensor([0]))
    chunk = dp.act(obs, torch.Generator().manual_seed(0))
    assert len(calls) == steps and calls == sorted(calls, reverse=True)  # from noisy to clean
    assert torch.isfinite(chunk.actions).all()
    with pytest.raises(ScdpError, match="sampler"):
        loaders.load_method("dp", tiny_ckpt, NAVIGATION, PlanningOptions(sampler="euler"))
