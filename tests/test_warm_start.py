"""Warm starts across chunks: exactly cold at skip 0, cold on a style flip or off the plan, and fewer
network calls per chunk when warm (counted, not timed)."""

import numpy as np
import pytest
import torch

from scdp.config import PlanningOptions
from scdp.policies.base import WarmStart, observe_histories
from scdp.policies.control import ControlLoopPolicy
from scdp.policies.loaders import load_method
from scdp.tasks import NAVIGATION

GOALS = np.array([[1.6, 0.6], [1.6, -0.6]])


@pytest.fixture
def checkpoints(tiny_ckpt):
    """The session's tiny Navigation checkpoints (base, encoder, both style predictors)."""
    return tiny_ckpt


def planner(checkpoints, method="dp", skip=0, steps=8):
    return load_method(method, checkpoints, NAVIGATION, planning=PlanningOptions(sampler="ddpm", steps=steps,
                                                                                  warm_skip=skip))


def count_calls(policy, monkeypatch) -> list:
    calls = []
    unet = policy.unet if hasattr(policy, "unet") else policy.base.unet
    real = unet.forward
    monkeypatch.setattr(unet, "forward", lambda *a, **kw: calls.append(1) or real(*a, **kw))
    return calls


def _obs(states):
    return observe_histories(NAVIGATION, [states], [GOALS], [0], 2)


def test_a_warm_start_at_skip_0_is_exactly_the_cold_start(checkpoints):
    dp = planner(checkpoints)
    cond = torch.randn(2, dp.config.global_cond_dim)
    init = torch.randn(2, dp.config.horizon, dp.config.state_dim)
    cold = dp.sample(cond, generator=[torch.Generator().manual_seed(i) for i in (1, 2)])
    warm = dp.sample(cond, generator=[torch.Generator().manual_seed(i) for i in (1, 2)], init=init,
                     warm=torch.tensor([True, True]))
    assert torch.equal(cold, warm)
    dp.use_warm_start(4)  # now the same call starts from init, re-noised: another sample
    assert not torch.allclose(cold, dp.sample(cond, generator=[torch.Generator().manual_seed(i) for i in (1, 2)],
                                              init=init, warm=torch.tensor([True, True])))


def test_warm_chunks_cost_fewer_network_calls_and_are_counted(checkpoints, monkeypatch):
    per_chunk = {}
    for skip in (0, 4):
        dp = planner(checkpoints, skip=skip)
        calls = count_calls(dp, monkeypatch)
        policy = ControlLoopPolicy(dp, NAVIGATION, GOALS, 0, seed=3)
        state = NAVIGATION.make_env().reset(seed=3, options={"goals": GOALS, "target": 0})[0]["state"]
        policy.reset(state)
        for _ in range(3):
            chunk = policy.predict_action_chunk()
            policy.observe(chunk)
        per_chunk[skip] = (len(calls), dict(policy.starts))
    assert per_chunk[0] == (3 * 8, {"off": 3})
    calls, starts = per_chunk[4]
    assert starts == {"first": 1, "warm": 2} and calls == 8 + 2 * (8 - 4)


def test_a_style_flip_or_a_robot_off_its_plan_starts_cold(checkpoints):
    scdp = planner(checkpoints, "scdp", skip=4)
    scdp.style = "legible"
    state = NAVIGATION.make_env().reset(seed=0, options={"goals": GOALS, "target": 0})[0]["state"]
    obs = _obs([state])
    first = scdp.act(obs, [torch.Generator().manual_seed(0)], WarmStart.cold_start(1))
    assert first.starts == ["first"] and first.weights.tolist() == [1.0]
    # where the first chunk's actions took the robot: the plan is followed, the style kept
    taken = len(first.actions[0])
    followed = _obs([state, *first.actions[0].numpy()])
    assert scdp.act(followed, [torch.Generator().manual_seed(0)], WarmStart.from_chunk(first, taken)).starts == ["warm"]
    scdp.style = "efficient"  # the style flipped since the last chunk
    assert scdp.act(followed, [torch.Generator().manual_seed(0)], WarmStart.from_chunk(first, taken)).starts == ["style"]
    scdp.style = "legible"
    pushed = _obs([state, *(first.actions[0].numpy() + np.array([0.3, 0.0, 0.0]))])  # the robot was pushed
    assert scdp.act(pushed, [torch.Generator().manual_seed(0)], WarmStart.from_chunk(first, taken)).starts == ["jump"]


def test_the_control_loop_starts_cold_after_set_style_and_a_dropped_queue(checkpoints):
    scdp = planner(checkpoints, "scdp", skip=4)
    policy = ControlLoopPolicy(scdp, NAVIGATION, GOALS, 0, seed=1)
    state = NAVIGATION.make_env().reset(seed=1, options={"goals": GOALS, "target": 0})[0]["state"]
    policy.reset(state)
    policy.observe(policy.predict_action_chunk())
    policy.set_style("legible")
    policy.observe(policy.predict_action_chunk())
    policy.drop_queued_actions()
    policy.predict_action_chunk()
    assert policy.starts == {"first": 1, "style": 1, "dropped": 1}


def test_ddpm_steps_with_constants_computed_once_are_the_schedulers_bit_for_bit(checkpoints, monkeypatch):
    from scdp.policies import diffusion

    dp = planner(checkpoints, steps=10)
    cond = torch.randn(3, dp.config.global_cond_dim)
    fast = dp.sample(cond, generator=[torch.Generator().manual_seed(i) for i in range(3)])
    monkeypatch.setattr(diffusion.DDPMSteps, "supports", staticmethod(lambda scheduler: False))
    slow = dp.sample(cond, generator=[torch.Generator().manual_seed(i) for i in range(3)])
    assert torch.equal(fast, slow)
