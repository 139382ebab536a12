"""Warm starts across chunks: exactly cold at skip 0, cold on a style flip or off the plan, and fewer
network calls per chunk when warm (counted, not timed); through the planning service too, where the
client sends the last answer back."""

import json

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
    """The default DDPM path (constants once, no diffusers) plans what diffusers' DDPMScheduler plans
    step by step, from the same generators."""
    from scdp.policies import diffusion, schedulers

    dp = planner(checkpoints, steps=10)
    cond = torch.randn(3, dp.config.global_cond_dim)
    fast = dp.sample(cond, generator=[torch.Generator().manual_seed(i) for i in range(3)])
    assert isinstance(dp.sampler(), diffusion.DDPMSteps)
    dp._sampler = (dp.config, schedulers.make_sampler(dp.config))  # diffusers' own DDPM, stepped by its step()
    slow = dp.sample(cond, generator=[torch.Generator().manual_seed(i) for i in range(3)])
    assert torch.equal(fast, slow)


# -- the planning service: the client sends the last answer back ------------------------------------
@pytest.fixture
def warm_service(checkpoints):
    from scdp.serve.app import PlanningService

    return PlanningService(checkpoints, "navigation", methods=["dp", "scdp_legible", "scdp_efficient"],
                           planning=PlanningOptions(sampler="ddpm", steps=8, warm_skip=4))


def _request(history, seed, previous=None):
    return {"history": np.asarray(history, dtype=np.float64), "goals": GOALS, "target": 0, "seed": seed, "previous": previous}


def _sent_back(service, spec, answer, executed):
    """What a client sends back: the answer's plan and weight as JSON carried them, checked by the service."""
    from scdp.serve.app import PreviousChunk

    return service.check_previous(spec, PreviousChunk(plan=answer["plan"], weight=answer["weight"], executed=executed))


@pytest.mark.parametrize("method", ["dp", "scdp_legible"])
def test_the_service_starts_warm_from_the_answer_sent_back_as_the_planner_does(warm_service, method, monkeypatch):
    from scdp.config import PlannerSpec
    from scdp.policies.control import plan_chunks

    spec = PlannerSpec.parse(method)
    planner = warm_service.planner(spec)
    calls = count_calls(planner, monkeypatch)
    state = NAVIGATION.make_env().reset(seed=3, options={"goals": GOALS, "target": 0})[0]["state"]
    n = warm_service.meta["config"]["n_action_steps"]
    (actions, answer, _), = warm_service._plan_group((spec, 0, n), [_request([state], 5)])
    assert answer["start"] == "first" and len(calls) == 8
    history = [state, *actions]
    previous = _sent_back(warm_service, spec, answer, n)
    (again, warm_answer, _), = warm_service._plan_group((spec, 0, n), [_request(history, 6, previous)])
    assert warm_answer["start"] == "warm" and len(calls) == 8 + 4  # the warm chunk skipped 4 of 8 steps
    # the same chunk as the planner plans from the Chunk itself (no JSON in between)
    first = plan_chunks(planner, NAVIGATION, [[state]], [GOALS], [0], [torch.Generator().manual_seed(5)],
                        warm=WarmStart.cold_start(1))
    direct = plan_chunks(planner, NAVIGATION, [history], [GOALS], [0], [torch.Generator().manual_seed(6)],
                         warm=WarmStart.from_chunk(first, n))
    assert np.array_equal(again, direct.actions[0]) and direct.starts == ["warm"]
    # without the answer sent back the same request starts cold, and plans another chunk
    (cold, cold_answer, _), = warm_service._plan_group((spec, 0, n), [_request(history, 6)])
    assert cold_answer["start"] == "first" and not np.array_equal(cold, again)


def test_the_service_starts_cold_after_a_style_change_or_off_the_plan(warm_service):
    from scdp.config import PlannerSpec

    legible, efficient = PlannerSpec.parse("scdp_legible"), PlannerSpec.parse("scdp_efficient")
    state = NAVIGATION.make_env().reset(seed=1, options={"goals": GOALS, "target": 0})[0]["state"]
    n = warm_service.meta["config"]["n_action_steps"]
    (actions, answer, _), = warm_service._plan_group((legible, 0, n), [_request([state], 1)])
    history = [state, *actions]
    back = _sent_back(warm_service, legible, answer, n)
    pushed = [state, *(actions + np.array([0.3, 0.0, 0.0]))]
    starts = [a["start"] for _, a, _ in warm_service._plan_group((legible, 0, n), [_request(history, 2, back),
                                                                                   _request(pushed, 2, back),
                                                                                   _request(history, 2)])]
    assert starts == ["warm", "jump", "first"]  # one batch, each row by its own rule
    (_, switched, _), = warm_service._plan_group((efficient, 0, n), [_request(history, 2, back)])
    assert switched["start"] == "style" and switched["weight"] == 0.0 and answer["weight"] == 1.0


def test_a_previous_answer_that_cannot_be_one_is_refused_on_its_field(warm_service):
    from fastapi.testclient import TestClient

    from scdp.serve.app import create_app

    cfg = warm_service.meta["config"]
    plan = [[0.1, 0.0, 0.0]] * cfg["horizon"]
    act = {"state_history": [[0.0, 0.0, 0.0]], "goals": GOALS.tolist(), "target": 0, "method": "scdp_legible", "seed": 1}
    cases = [
        ({"plan": plan[:-1], "weight": 1.0, "executed": 2}, "previous.plan"),  # not the model's horizon
        ({"plan": [[0.1, 0.0]] * cfg["horizon"], "weight": 1.0, "executed": 2}, "previous.plan"),
        ({"plan": [[1e308 * 10, 0.0, 0.0]] + plan[1:], "weight": 1.0, "executed": 2}, "previous.plan"),
        ({"plan": plan, "weight": None, "executed": 2}, "previous.weight"),  # scdp's answers carry a weight
        ({"plan": plan, "weight": 1.5, "executed": 2}, "previous.weight"),
        ({"plan": plan, "weight": 1.0, "executed": cfg["n_action_steps"] + 1}, "previous.executed"),
        ({"plan": plan, "weight": 1.0, "executed": 0}, "previous.executed"),
        ({"plan": plan, "weight": 1.0}, "previous.executed"),
        ({"plan": plan, "weight": 1.0, "executed": 2, "velocity": 1}, "previous.velocity"),
        ({"plan": plan, "weight": 1.0, "executed": "2"}, "previous.executed"),
    ]
    with TestClient(create_app(warm_service)) as client:
        for previous, field in cases:
            body = json.dumps({**act, "previous": previous})  # inf goes as Infinity, as Python clients send it
            response = client.post("/v1/act", content=body, headers={"content-type": "application/json"})
            error = response.json()["error"]
            assert response.status_code == 422 and error.split(":")[0] == field and "\n" not in error, (previous, error)
        dp = client.post("/v1/act", json={**act, "method": "dp", "previous": {"plan": plan, "weight": 0.5, "executed": 2}})
        assert dp.status_code == 422 and dp.json()["error"].startswith("previous.weight: "), dp.text  # dp has no style


def test_a_chunks_noise_goes_to_the_device_in_one_copy():
    """Every draw of a chunk (start noise and each noisy step's) is a view of one tensor moved at once,
    with the values drawn one by one from the generators in the loop's order."""
    from scdp.policies.ddpm_steps import DDPMSteps, randn
    from scdp.policies.sampling import draw_noise

    steps = DDPMSteps(100, "squaredcos_cap_v2", True, 8)
    run = list(range(8))
    x, noises = draw_noise((2, 16, 3), [torch.Generator().manual_seed(s) for s in (0, 1)], steps, run, torch.device("cpu"))
    assert [z is None for z in noises] == [False] * 7 + [True]
    storage = x.untyped_storage().data_ptr()
    assert all(z.untyped_storage().data_ptr() == storage for z in noises if z is not None)
    generators = [torch.Generator().manual_seed(s) for s in (0, 1)]
    one_by_one = [randn((2, 16, 3), generators) for _ in range(8)]
    assert torch.equal(x, one_by_one[0]) and all(torch.equal(z, o) for z, o in zip(noises[:7], one_by_one[1:]))
