"""The contract a :class:`~scdp.tasks.base.Task` keeps, checked when a task from outside the library
is loaded (:func:`check_contract`), so a broken one is refused in one line naming the member
instead of failing an hour into training. docs/tasks.md explains each member.

Units: metres for task space, radians for angles, seconds for ``control_dt``. States are what
the robot reports and actions are the absolute next states (``state_dim`` each); task space is
the point the goals live in (``space_dim`` = 2 or 3).

Required of a subclass (the base raises NotImplementedError): :data:`REQUIRED_METHODS`.
Optional: ``check_reachable`` (refuse goals the robot cannot reach), ``start_noise``,
``viewer_eye``/``viewer_target`` (a viewpoint observer), ``lift_max`` (3-D tasks).
"""

from __future__ import annotations

import re

import gymnasium as gym
import numpy as np

from scdp.ambiguity import AmbiguitySettings
from scdp.envs.base import GoalReachEnv
from scdp.errors import ScdpError
from scdp.tasks.base import Task

REQUIRED_METHODS = ("task_space", "nominal_start", "actions_for_path", "make_env", "reach_used", "state_bounds",
                    "state_names")
NAME = re.compile(r"[a-z][a-z0-9_]{0,39}")  # a folder name in every run: lower case, digits, underscores
N_LAYOUTS = 6  # the labelled two-goal layouts that calibrate the ellipse and form the per-layout protocol
ENV_HOOKS = ("build_action_space", "reset_robot", "apply_action", "state", "draw")  # GoalReachEnv's, each required


class _Refusal(Exception):
    def __init__(self, member: str, problem: str):
        self.member, self.problem = member, problem


def _array(task: Task, member: str, shape: tuple) -> np.ndarray:
    value = getattr(task, member)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise _Refusal(member, f"must be numbers, got {type(value).__name__}") from None
    if arr.shape != shape:
        raise _Refusal(member, f"must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise _Refusal(member, "holds NaN or inf")
    return arr


def _positive(task: Task, member: str, integer: bool = False) -> None:
    value = getattr(task, member)
    kind = (int, np.integer) if integer else (int, float, np.integer, np.floating)
    if isinstance(value, bool) or not isinstance(value, kind) or not np.isfinite(value) or value <= 0:
        raise _Refusal(member, f"must be a positive {'integer' if integer else 'number'}, got {value!r}")


def _call(member: str, fn, *args):
    try:
        return fn(*args)
    except ScdpError:
        raise
    except Exception as exc:
        raise _Refusal(member, f"raised {type(exc).__name__}: {str(exc)[:80]}") from None


def _fields(task: Task) -> None:
    if not isinstance(task.name, str) or not NAME.fullmatch(task.name):
        raise _Refusal("name", f"must be lower case letters, digits and underscores, got {task.name!r}")
    _positive(task, "state_dim", integer=True)
    if task.space_dim not in (2, 3) or isinstance(task.space_dim, bool):
        raise _Refusal("space_dim", f"must be 2 (a plane) or 3 (x, y, z), got {task.space_dim!r}")
    d = task.space_dim
    low, high = _array(task, "goal_low", (d,)), _array(task, "goal_high", (d,))
    if not np.all(low <= high) or np.sum(low < high) < 2:  # Block Reach's blocks all sit at one height
        raise _Refusal("goal_high", f"must be >= goal_low everywhere and exceed it in two coordinates or more "
                                    f"({low.tolist()} vs {high.tolist()})")
    w_low, w_high = _array(task, "workspace_low", (d,)), _array(task, "workspace_high", (d,))
    if not (np.all(w_low <= low) and np.all(high <= w_high)):
        raise _Refusal("workspace_low", f"the workspace {w_low.tolist()}..{w_high.tolist()} must hold the goal box "
                                        f"{low.tolist()}..{high.tolist()}")
    for member in ("success_radius", "step_size", "min_goal_separation", "control_dt", "lateral_cap"):
        _positive(task, member)
    _positive(task, "max_episode_steps", integer=True)
    for member in ("lateral_max", "lift_max"):
        if not np.isfinite(getattr(task, member)) or getattr(task, member) < 0:
            raise _Refusal(member, f"must be a number >= 0, got {getattr(task, member)!r}")
    layouts = _array(task, "layouts", (N_LAYOUTS, 2, d))
    outside = np.any((layouts < w_low - 1e-9) | (layouts > w_high + 1e-9), axis=-1)  # (layouts, 2)
    if outside.any():
        i, k = (int(v[0]) for v in np.nonzero(outside))
        raise _Refusal("layouts", f"layout {i + 1} goal {k} {np.round(layouts[i, k], 4).tolist()} lies outside the "
                                  f"workspace {w_low.tolist()}..{w_high.tolist()}")
    labels = task.ambiguous_layouts
    if (not isinstance(labels, tuple) or not labels or len(labels) >= N_LAYOUTS
            or not all(isinstance(k, int) and 1 <= k <= N_LAYOUTS for k in labels)):
        raise _Refusal("ambiguous_layouts", f"must be a tuple of some (not all) of the layout numbers 1..{N_LAYOUTS}, "
                                            f"got {labels!r}")
    if not isinstance(task.ambiguity, AmbiguitySettings):
        raise _Refusal("ambiguity", f"must be a scdp.ambiguity.AmbiguitySettings, got {type(task.ambiguity).__name__}")
    noise = np.asarray(task.start_noise, dtype=np.float64)
    if noise.shape not in ((0,), (task.state_dim,)) or np.any(noise < 0) or not np.all(np.isfinite(noise)):
        raise _Refusal("start_noise", f"must be empty or {task.state_dim} standard deviations >= 0, got shape {noise.shape}")


def _methods(task: Task) -> None:
    for member in REQUIRED_METHODS:
        if getattr(type(task), member) is getattr(Task, member):
            raise _Refusal(member, "is required and not defined (docs/tasks.md)")
    if hasattr(task, "_check_reachable"):  # no longer called: a task relying on it would accept every goal
        raise _Refusal("_check_reachable", "is the hook's old name and is no longer called: rename it check_reachable")
    names, low, high, start = _state_layout(task)
    _kinematics(task, start)
    _environment(task, names, low, high)


def _state_layout(task: Task) -> tuple[list, np.ndarray, np.ndarray, np.ndarray]:
    """The state's names and bounds and the nominal start, each checked: (names, low (S,), high (S,), start (S,))."""
    n = task.state_dim
    bounds = _call("state_bounds", task.state_bounds)
    if not isinstance(bounds, tuple) or len(bounds) != 2:
        raise _Refusal("state_bounds", "must return (low, high)")
    low, high = (np.asarray(b, dtype=np.float64) for b in bounds)
    if low.shape != (n,) or high.shape != (n,):
        raise _Refusal("state_bounds", f"must return low and high of shape ({n},) each; got {low.shape} and {high.shape}")
    names = _call("state_names", lambda: task.state_names)
    if len(names) != n or not all(isinstance(s, str) for s in names):
        raise _Refusal("state_names", f"must name each of the {n} state coordinates, got {names!r}")
    bad = ~np.isfinite(low) | ~np.isfinite(high)
    if bad.any():
        j = int(np.argmax(bad))
        raise _Refusal("state_bounds", f"{names[j]} (coordinate {j}) has bounds {low[j]}..{high[j]}: each must be a "
                                       "finite number")
    if not np.all(low < high):
        j = int(np.argmax(low >= high))
        raise _Refusal("state_bounds", f"{names[j]} (coordinate {j}) has low {low[j]:.4g} >= high {high[j]:.4g}: low "
                                       "must be below high in every coordinate")
    start = np.asarray(_call("nominal_start", task.nominal_start), dtype=np.float64)
    if start.shape != (n,):
        raise _Refusal("nominal_start", f"must return shape ({n},), got {start.shape}")
    if np.any(start < low) or np.any(start > high):
        j = int(np.argmax((start < low) | (start > high)))
        raise _Refusal("nominal_start", f"{names[j]} = {start[j]:.4g} lies outside state_bounds {low[j]:.4g}..{high[j]:.4g}")
    return names, low, high, start


def _kinematics(task: Task, start: np.ndarray) -> None:
    """task_space, the layouts, reach_used and actions_for_path, each tried from the nominal start."""
    n, d = task.state_dim, task.space_dim
    point = np.asarray(_call("task_space", task.task_space, start))
    if point.shape != (d,):
        raise _Refusal("task_space", f"must map a state ({n},) to a point ({d},), got {point.shape}")
    many = np.asarray(_call("task_space", task.task_space, np.repeat(start[None, None], 3, axis=1)))
    if many.shape != (1, 3, d):
        raise _Refusal("task_space", f"must map states (..., {n}) to points (..., {d}); (1, 3, {n}) gave {many.shape}")
    for i, layout in enumerate(task.layouts):  # checked as a scene is: the workspace, apart, reachable, off the start
        try:
            task.validate_goals(layout, field="layouts")
        except ScdpError as exc:
            raise _Refusal("layouts", f"layout {i + 1}: {exc.message}") from None
    reach = np.asarray(_call("reach_used", task.reach_used, start[None], start[None]))
    if reach.shape != (1,) or not np.isfinite(reach[0]) or abs(reach[0]) > 1e-9:
        raise _Refusal("reach_used", f"must return (T,) ratios, 0 for staying put; got {reach!r}")
    goal = (np.asarray(task.goal_low) + np.asarray(task.goal_high)) / 2
    steps = max(2, int(np.ceil(np.linalg.norm(goal - point) / task.step_size)) + 1)
    path = np.linspace(point, goal, steps)
    actions = _call("actions_for_path", task.actions_for_path, path, start)
    if actions is None:
        raise _Refusal("actions_for_path", f"cannot follow a straight path from the start to the goal box's centre "
                                           f"{np.round(goal, 3).tolist()}")
    actions = np.asarray(actions, dtype=np.float64)
    if actions.ndim != 2 or actions.shape[1] != n or len(actions) < len(path) - 1:
        raise _Refusal("actions_for_path", f"must return (at least K - 1, {n}) next states for a path of K points, "
                                           f"got {actions.shape} for K = {len(path)}")
    end = np.asarray(task.task_space(actions[-1]))
    if np.linalg.norm(end - goal) > task.success_radius:
        raise _Refusal("actions_for_path", f"ends {np.linalg.norm(end - goal):.3f} m from the path's end (task_space "
                                           f"of its last state), more than success_radius {task.success_radius}"
                                           + _looks_like_deltas(task, start, actions, goal))

def _looks_like_deltas(task: Task, start: np.ndarray, actions: np.ndarray, goal: np.ndarray) -> str:
    """A hint when ``actions`` summed from ``start`` would reach ``goal``: steps, not next states."""
    try:
        summed = np.asarray(task.task_space(start + np.cumsum(actions, axis=0)[-1]), dtype=np.float64)
    except Exception:  # noqa: BLE001 - a hint only: the refusal stands without it
        return ""
    if summed.shape == goal.shape and np.linalg.norm(summed - goal) <= task.success_radius:
        return ("; summed from the start, the actions do reach it: they look like steps (deltas), but an action is the "
                "absolute next state (start + step)")
    return ""


def _environment(task: Task, names, low: np.ndarray, high: np.ndarray) -> None:
    """Build, reset, step and draw the environment: its hooks exist and run, and it keeps the state
    inside ``state_bounds()`` over an episode of actions beyond them (from the start, every step
    commanding a state past the high bound, then past the low one)."""
    env = _call("make_env", task.make_env)
    if not isinstance(env, gym.Env):
        raise _Refusal("make_env", f"must return a gymnasium.Env, got {type(env).__name__}")
    name = type(env).__name__
    if isinstance(env, GoalReachEnv):
        for hook in ENV_HOOKS:
            if getattr(type(env), hook) is getattr(GoalReachEnv, hook):
                raise _Refusal("make_env", f"the environment {name} does not define {hook} (docs/tasks.md)")
    goals, n = np.asarray(task.layouts[0], dtype=np.float64), task.state_dim
    try:
        for side, beyond in (("high", high + (high - low)), ("low", low - (high - low))):
            _call(f"make_env: {name}.reset (reset_robot)", lambda: env.reset(seed=0, options={"goals": goals, "target": 0}))
            for step in range(1, task.max_episode_steps + 1):
                obs, *_ = _call(f"make_env: {name}.step (apply_action)", env.step, beyond)
                state = np.asarray(obs["state"] if isinstance(obs, dict) else obs, dtype=np.float64).reshape(-1)
                if state.shape != (n,):
                    raise _Refusal("make_env", f"the environment's state must have shape ({n},), got {state.shape}")
                out = (state < low) | (state > high)
                if out.any():
                    j = int(np.argmax(out))
                    raise _Refusal("make_env", f"commanded past its {side} bound, the environment's state left "
                                               f"state_bounds at step {step} ({names[j]} = {state[j]:.4g}, bounds "
                                               f"{low[j]:.4g}..{high[j]:.4g}): clip the state to state_bounds() in "
                                               "apply_action (docs/tasks.md)")
        if isinstance(env, GoalReachEnv) and type(env).render is GoalReachEnv.render:  # the library's drawing
            _call(f"make_env: {name}.render (draw)", env.render)
    finally:
        env.close()


def check_contract(task: Task, reference: str) -> Task:
    """``task``, after checking every member the library reads; else :class:`ScdpError` on
    ``task`` naming ``reference``, the member and what is wrong with it."""
    try:
        _fields(task)
        _methods(task)
    except _Refusal as refusal:
        raise ScdpError("task", f"{reference}: {refusal.member}: {refusal.problem}") from None
    except ScdpError as exc:
        raise ScdpError("task", f"{reference}: {exc.field}: {exc.message}") from None
    return task
