"""The control-loop policy (scdp.policies.control): the queue, reset, a style change that takes
effect at once, and the same chunks as a rollout; torch and ONNX Runtime, both tasks."""

import numpy as np
import pytest

from scdp.config import PlanningOptions
from scdp.errors import ScdpError
from scdp.evaluation.rollout import rollout
from scdp.policies.control import ControlLoopPolicy
from scdp.policies.loaders import load_method
from scdp.tasks import get_task

SCENES = {"navigation": ([[2.0, 0.4], [2.0, -0.4]], 0), "block_reach": ([[0.5, 0.1, 0.1], [0.5, -0.1, 0.1]], 1)}


@pytest.fixture(scope="module")
def checkpoints(exported_tiny):
    return exported_tiny


def policy_for(checkpoints, task, method="scdp", runtime="torch", seed=3):
    task_obj = get_task(task)
    planner = load_method(method, checkpoints / task, task_obj, PlanningOptions(runtime=runtime))
    goals, target = SCENES[task]
    return ControlLoopPolicy(planner, task_obj, goals, target, seed=seed), planner, task_obj


@pytest.mark.parametrize("runtime", ["torch", "onnx"])
@pytest.mark.parametrize("task", list(SCENES))
def test_a_chunk_is_planned_when_the_queue_runs_dry_and_matches_the_rollout(checkpoints, task, runtime):
    policy, planner, task_obj = policy_for(checkpoints, task, runtime=runtime)
    (run,) = rollout(task_obj, planner, [SCENES[task]], seeds=[3])
    n = planner.n_action_steps
    policy.reset(run.states[0])
    first = [policy.select_action(run.states[0])]
    for k in range(1, n):  # the robot executes the queue: no replanning in between
        first.append(policy.select_action(run.states[k]))
    assert len(policy.styles) == 1 and not policy.queue
    assert np.allclose(first, run.actions[:n], atol=1e-6)  # same seed, same noise as the rollout
    policy.select_action(run.states[n])
    assert len(policy.styles) == 2 and len(policy.queue) == n - 1
    policy.reset(run.states[0])
    assert not policy.queue and policy.styles == [] and np.allclose(policy.select_action(run.states[0]), first[0])


def test_a_style_change_takes_effect_at_the_next_action(checkpoints):
    policy, planner, task_obj = policy_for(checkpoints, "navigation", method="scdp")
    state = task_obj.nominal_start()
    policy.reset(state)
    policy.set_style("efficient")
    policy.select_action(state)
    assert policy.styles[-1] == "efficient" and policy.queue
    policy.set_style("legible")  # drops the rest of the efficient chunk
    assert not policy.queue
    policy.select_action(state)
    assert policy.styles[-1] == "legible"
    assert policy.drop_queued_actions() == planner.n_action_steps - 1 and policy.drop_queued_actions() == 0


def test_the_refusals(checkpoints):
    dp, _, task_obj = policy_for(checkpoints, "navigation", method="dp")
    with pytest.raises(ScdpError, match="only SCDP"):
        dp.set_style("legible")
    legible_only, _, _ = policy_for(checkpoints, "navigation", method="scdp_legible")
    with pytest.raises(ScdpError, match="needs the efficient predictor"):
        legible_only.set_style("auto")
    with pytest.raises(ScdpError) as err:
        dp.select_action([0.0, 0.0])
    assert err.value.field == "state"
