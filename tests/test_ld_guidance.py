"""Legibility Diffuser's guided noise estimate against its formula, and its noise window:
ε̃ = (1 + w) ε(g*) − α w ε(g⁻) − (1 − α) w ε(∅) inside the window, ε(g*) alone below it."""

import dataclasses

import pytest
import torch

from helpers.tiny import TINY
from scdp.config import GuidanceConfig
from scdp.policies import loaders
from scdp.policies.base import Observation
from scdp.policies.legibility_diffuser import LegibilityDiffuser, guidance_weights
from scdp.presets import PRESETS
from scdp.tasks import NAVIGATION
from scdp.training.parts import build_diffusion


def _captured_eps_fn(guidance):
    """The eps_fn LD hands to the sampler for one two-goal scene, and the conditions it stacked."""
    policy = build_diffusion(NAVIGATION, PRESETS["tiny"], ld=True).eval()
    seen = {}

    def fake_sample(cond, generator=None, eps_fn=None, **_):
        seen["eps_fn"] = eps_fn
        return torch.zeros(cond.shape[0], policy.config.horizon, policy.config.state_dim)

    policy.sample = fake_sample
    state = torch.tensor([[[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]]])
    goals = torch.tensor([[[2.0, 0.3], [2.0, -0.3]]])
    obs = Observation(state, state[:, -1, :2], goals, torch.tensor([0]))
    LegibilityDiffuser(policy, guidance).act(obs)
    conds = [policy.observe(state, goals[:, 0]), policy.observe(state, goals[:, 1]), policy.observe(state, None)]
    return policy, seen["eps_fn"], conds


def _expected(policy, conds, x, k, w, alpha):
    e_pos, e_neg, e_null = (policy.unet(x, k, c) for c in conds)
    return (1 + w) * e_pos - alpha * w * e_neg - (1 - alpha) * w * e_null, e_pos


def test_guided_estimate_matches_the_formula_at_every_step():
    torch.manual_seed(0)
    policy, eps_fn, conds = _captured_eps_fn(GuidanceConfig(w0=2.0, alpha=0.7))
    x = torch.randn(1, policy.config.horizon, policy.config.state_dim)
    with torch.no_grad():
        for step in (0, 50, 99):
            k = torch.tensor([step])
            guided, plain = _expected(policy, conds, x, k, 2.0, 0.7)
            assert torch.allclose(eps_fn(x, k, step), guided, atol=1e-5)
            assert not torch.allclose(guided, plain, atol=1e-3)  # the guidance does move the estimate


def test_the_window_guides_only_the_noisiest_steps():
    torch.manual_seed(0)
    policy, eps_fn, conds = _captured_eps_fn(GuidanceConfig(w0=2.0, alpha=0.7, window=0.4))
    x = torch.randn(1, policy.config.horizon, policy.config.state_dim)
    with torch.no_grad():
        guided, _ = _expected(policy, conds, x, torch.tensor([80]), 2.0, 0.7)
        assert torch.allclose(eps_fn(x, torch.tensor([80]), 80), guided, atol=1e-5)  # k >= 60: guided
        _, plain = _expected(policy, conds, x, torch.tensor([30]), 2.0, 0.7)
        assert torch.allclose(eps_fn(x, torch.tensor([30]), 30), plain, atol=1e-5)  # below: ε(g*) alone


def test_guidance_weights_sum_to_one():
    for w, a in [(4.5, 0.9), (0.3, 0.1), (10.0, 0.5)]:
        assert sum(guidance_weights(w, a)) == pytest.approx(1.0)


def test_ld_decays_once_per_chunk(tiny_ckpt):
    ld = loaders.load_method("ld", tiny_ckpt, NAVIGATION)
    goals = torch.tensor(NAVIGATION.layouts[0], dtype=torch.float32)[None]
    obs = Observation(state_hist=torch.zeros(1, 2, 3), position=torch.zeros(1, 2), goals=goals, target=torch.tensor([0]))
    w0, decay = TINY.ld.guidance.w0, TINY.ld.guidance.decay  # saved in the checkpoint
    assert decay < 1
    ld.reset()
    assert ld.w == w0
    ld.act(obs, torch.Generator().manual_seed(0))
    assert ld.w == pytest.approx(w0 * decay)
    ld.act(obs, torch.Generator().manual_seed(0))
    assert ld.w == pytest.approx(w0 * decay**2)
    ld.reset()
    assert ld.w == w0


def test_ld_guidance_is_one_batched_forward(tiny_ckpt, monkeypatch):
    ld = loaders.load_method("ld", tiny_ckpt, NAVIGATION)
    ld.guidance = dataclasses.replace(ld.guidance, window=1.0)  # guided at every step (the window: test_ld_guidance.py)
    calls = []
    original = ld.policy.unet.forward
    monkeypatch.setattr(ld.policy.unet, "forward", lambda x, k, c, film=None: calls.append(len(x)) or original(x, k, c, film))
    goals = torch.tensor(NAVIGATION.layouts[0], dtype=torch.float32)[None].repeat(4, 1, 1)
    obs = Observation(state_hist=torch.zeros(4, 2, 3), position=torch.zeros(4, 2), goals=goals, target=torch.zeros(4, dtype=torch.long))
    ld.act(obs)
    assert calls == [12] * TINY.base.model.num_inference_steps  # 3 conditions x 4 scenes, once per denoising step
