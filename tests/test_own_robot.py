"""A robot of your own on the first try: a rollout that leaves the bounds fails alone and is
counted; an environment that does not keep its state inside the bounds, misses a hook, or takes
2-D goals on a 3-D task is refused at load in one line naming the value."""

from dataclasses import dataclass, fields, replace

import numpy as np
import pytest
import torch

from helpers.refusals import refused_at_load, user_module
from scdp.data.scenes import scene_seed
from scdp.errors import ScdpError
from scdp.evaluation.protocol import evaluate_methods
from scdp.evaluation.records import early_failures, failures_line
from scdp.evaluation.rollout import rollout
from scdp.policies.base import Chunk
from scdp.tasks import BLOCK_REACH, NAVIGATION, NavigationTask, get_task
from scdp.tasks.contract import check_contract

# a user's module: 2-D point robots, one sound (ClippedEnv) and several broken
USER_MODULE = '''
from dataclasses import dataclass, fields
import numpy as np
from gymnasium import spaces
from scdp.envs.base import GoalReachEnv
from scdp.tasks import NAVIGATION, Task

class PointEnv(GoalReachEnv):
    def build_action_space(self):
        return spaces.Box(-np.inf, np.inf, (2,), np.float64)
    def reset_robot(self, state):
        self._s = np.array(state, dtype=np.float64)
    @property
    def state(self):
        return self._s
    def apply_action(self, action):  # a units bug (x 1.6), and no clipping to the bounds
        self._s = 1.6 * np.asarray(action, dtype=np.float64)
    def draw(self, fig):
        fig.add_subplot(1, 1, 1).plot(*np.array(self.trail).T)

class ClippedEnv(PointEnv):
    def apply_action(self, action):
        super().apply_action(action)
        self._s = np.clip(self._s, *self.task.state_bounds())

class NoResetEnv(GoalReachEnv):  # every hook but reset_robot
    build_action_space, draw, state = PointEnv.build_action_space, PointEnv.draw, PointEnv.state
    def apply_action(self, action):
        self._s = np.asarray(action, dtype=np.float64)

class BadDrawEnv(ClippedEnv):
    def draw(self, fig):
        raise ValueError("no axes today")

@dataclass(frozen=True, eq=False)
class Point(Task):
    def task_space(self, states):
        return np.asarray(states, dtype=np.float64)[..., :2]
    def nominal_start(self):
        return np.zeros(2)
    def actions_for_path(self, path, start_state):
        return np.asarray(path, dtype=np.float64)[1:]
    def make_env(self, **kwargs):
        return {"drifter": PointEnv, "no_reset": NoResetEnv, "bad_draw": BadDrawEnv}.get(self.name, ClippedEnv)(self, **kwargs)
    def reach_used(self, states, actions):
        return np.linalg.norm(np.asarray(actions) - np.asarray(states), axis=-1) / 0.3
    def state_bounds(self):
        return self.workspace_low - 0.05, self.workspace_high + 0.05
    @property
    def state_names(self):
        return ("x", "y")

class FarStart(Point):
    def nominal_start(self):
        return np.array([0.0, 9.0])

class Deltas(Point):
    def actions_for_path(self, path, start_state):
        return np.diff(np.asarray(path, dtype=np.float64), axis=0)

def point(cls, name, **changes):
    values = {f.name: getattr(NAVIGATION, f.name) for f in fields(Task)}
    return cls(**{**values, "name": name, "state_dim": 2, "start_noise": np.zeros(0), **changes})

GOOD = point(Point, "my_point")
DRIFTS = point(Point, "drifter")
NO_HOOK = point(Point, "no_reset")
BAD_DRAW = point(Point, "bad_draw")
START = point(FarStart, "far_start")
FAR = NAVIGATION.layouts.copy()
FAR[1, 1] = [0.5, 9.0]  # layout 2's second goal, beyond the room
LAYOUT = point(Point, "far_layout", layouts=FAR)
DELTAS = point(Deltas, "deltas")
'''


@pytest.fixture
def user_folder(tmp_path, monkeypatch):
    return user_module(tmp_path, monkeypatch, "own_robot", USER_MODULE)


class Walker:
    """Heads for the target 0.1 m a step; in a scene whose target lies at y > 0 (``wild``) it plans its
    third step 50 m to the side, out of the room: a planner gone wrong, in one scene only."""

    def __init__(self, wild: bool = True):
        self.wild = wild

    n_obs_steps, n_action_steps, n_goals, style_modes, denoiser_parameters = 2, 4, None, (), 0

    def reset(self):
        pass

    def act(self, obs, generator=None):
        states, goals = obs.state_hist[:, -1].double().numpy(), obs.goals.double().numpy()
        chunks = []
        for state, g, t in zip(states, goals, obs.target.numpy()):
            step = (g[t] - state[:2]) / max(np.linalg.norm(g[t] - state[:2]), 1e-9) * 0.1
            xy = state[:2] + step * np.arange(1, 5)[:, None]  # (4, 2)
            if self.wild and g[t][1] > 0:
                xy[2, 1] += 50.0
            chunk = np.c_[xy, np.full(4, np.arctan2(step[1], step[0]))] if len(state) == 3 else xy
            chunks.append(chunk)
        return Chunk(torch.as_tensor(np.stack(chunks)), ["none"] * len(states))


SCENES = [(np.array([[2.0, -0.8], [2.0, 0.8]]), 0), (np.array([[2.0, -0.8], [2.0, 0.8]]), 1),
          (np.array([[1.5, -1.0], [2.5, 0.2]]), 0)]


def test_a_planner_that_walks_out_of_the_bounds_fails_that_rollout_alone():
    runs = rollout(NAVIGATION, Walker(), SCENES, seed=3)
    assert [bool(r.failure) for r in runs] == [False, True, False]
    assert runs[1].failure.startswith("planned action out of bounds: step 2: y = ")
    assert "is outside the navigation bounds" in runs[1].failure and not runs[1].success
    alone = rollout(NAVIGATION, Walker(), [SCENES[0], SCENES[2]], seeds=[scene_seed(3, "", 0), scene_seed(3, "", 2)])
    for mine, solo in zip((runs[0], runs[2]), alone):  # the others are unchanged by it
        assert np.array_equal(np.asarray(mine.path), np.asarray(solo.path)) and mine.success == solo.success
    # evaluated and reported: the failure is counted per method, with its reason
    records = evaluate_methods(NAVIGATION, {"walker": Walker()}, {"random": SCENES}, seed=3, progress=False)
    assert [r.failure is not None for r in records] == [False, True, False]
    assert list(early_failures(records)) == ["walker"] and len(early_failures(records)["walker"]) == 1
    assert failures_line(records).startswith("Rollouts ended early, each counted as a failure of that rollout alone: "
                                             "walker 1 of 3 (first: planned action out of bounds")
    assert "failure" not in records[0].to_dict() and records[1].to_dict()["failure"] == records[1].failure


def test_an_environment_that_lets_the_state_out_ends_its_rollout_with_the_reason(user_folder):
    import own_robot
    task = own_robot.DRIFTS  # not through get_task: the load check would refuse it (below)
    runs = rollout(task, Walker(wild=False), [(np.array([[2.0, -0.8], [2.0, 0.8]]), 0)], seed=0)
    assert runs[0].failure.startswith("left the state bounds at step ") and "x = " in runs[0].failure
    assert not runs[0].success and len(runs[0].actions) < task.max_episode_steps


@pytest.mark.parametrize("reference, message", [
    ("own_robot:DRIFTS", "make_env: commanded past its high bound, the environment's state left state_bounds at step 1 "
                         "(x = "),
    ("own_robot:NO_HOOK", "make_env: the environment NoResetEnv does not define reset_robot"),
    ("own_robot:BAD_DRAW", "make_env: BadDrawEnv.render (draw): raised ValueError: no axes today"),
    ("own_robot:START", "nominal_start: y = 9 lies outside state_bounds -2.55..2.55"),
    ("own_robot:LAYOUT", "layouts: layout 2 goal 1 [0.5, 9.0] lies outside the workspace"),
    ("own_robot:DELTAS", "they look like steps (deltas), but an action is the absolute next state"),
])
def test_a_broken_robot_is_refused_at_load_naming_the_value(user_folder, capsys, reference, message):
    refused_at_load(reference, message, user_folder, capsys)


def test_the_good_point_robot_passes(user_folder):
    assert get_task("own_robot:GOOD").name == "my_point"


def test_2d_goals_are_lifted_only_on_a_flat_goal_box():
    table = [[0.5, 0.2], [0.5, -0.2]]
    assert BLOCK_REACH.validate_goals(table, 0)[:, 2].tolist() == [BLOCK_REACH.goal_low[2]] * 2  # the table's height
    tall = replace(BLOCK_REACH, goal_high=BLOCK_REACH.goal_high + np.array([0.0, 0.0, 0.2]))
    with pytest.raises(ScdpError, match=r"^goals: block_reach goals have 3 coordinates, got 2 \(2-D goals are lifted "
                                        r"only on a 3-D task whose goal box is flat in z"):
        tall.validate_goals(table, 0)


@dataclass(frozen=True, eq=False)
class NearGoalsOnly(NavigationTask):
    def check_reachable(self, goals, field):  # the public hook
        if np.any(goals[:, 0] > 3.0):
            raise ScdpError(field, "beyond the cable's reach")


@dataclass(frozen=True, eq=False)
class OldNearGoalsOnly(NavigationTask):
    def _check_reachable(self, goals, field):  # the hook's old name, no longer called
        if np.any(goals[:, 0] > 3.0):
            raise ScdpError(field, "beyond the cable's reach")


def test_check_reachable_refuses_goals_it_names():
    task = NearGoalsOnly(**{f.name: getattr(NAVIGATION, f.name) for f in fields(NAVIGATION)})
    assert task.validate_goals([[2.5, 0.5], [2.5, -0.5]], 0).shape == (2, 2)
    with pytest.raises(ScdpError, match="^goals: beyond the cable's reach$"):
        task.validate_goals([[3.5, 0.5], [2.5, -0.5]], 0)


def test_a_task_with_the_old_private_hook_is_refused_at_load():
    """The hook's old name is no longer called: a task still defining it would accept every goal, so
    loading it is refused, naming the rename."""
    task = OldNearGoalsOnly(**{f.name: getattr(NAVIGATION, f.name) for f in fields(NAVIGATION)} | {"name": "old_hook"})
    with pytest.raises(ScdpError, match=r"^task: tests:OldNearGoalsOnly: _check_reachable: is the hook's old name and is no longer called: "
                                        r"rename it check_reachable"):
        check_contract(task, "tests:OldNearGoalsOnly")
