"""A task's content key, by what it does: every output made from a task is redone when it changes.

The key (:func:`task_key`) has two parts:

* ``fields``: the task's dataclass fields as JSON (dimensions, sampling boxes, demonstration bends
  such as ``lateral_cap``, the calibrated ambiguity settings, the layouts, ...), so a changed field
  is named in the log with both values;
* ``probe``: the digest of each of a fixed set of behaviour probes, run on seeded inputs: the
  task's hooks (``nominal_start``, ``start_state``, ``state_bounds``, ``task_space``,
  ``sample_goals``, ``check_reachable``), a few seeded demonstrations generated as the demos stage
  makes them (Bézier paths, ``actions_for_path``, the environment following them), and the
  environment stepped with seeded actions from the nominal start.

So a change anywhere a task's behaviour comes from (its methods, a helper module's constant such
as an arm's link lengths, an IK solver, an environment's controller) changes the key, while a
renamed variable, a docstring or a comment does not. Probe outputs are rounded to
:data:`SIGNIFICANT` significant digits before hashing, so the key is the same on any CPU. What the
library's :class:`~scdp.tasks.Task` base does is covered too (it runs in the probes); what stages
write is versioned by :data:`scdp.content.FORMAT`.
"""

from __future__ import annotations

import dataclasses
import json
import weakref

import numpy as np

from scdp.content import digest
from scdp.data.generate import generate_demos
from scdp.data.scenes import TASK_KEY, stream_rng
from scdp.errors import ScdpError
from scdp.tasks import Task

SIGNIFICANT = 6  # digits of every probe output that enter the key
PROBE_DEMOS = 3  # demonstrations generated, as the demos stage makes them
PROBE_STATES = 16  # states drawn inside the bounds for task_space
PROBE_SCENES = 8  # goal sets drawn (sample_goals) and candidate goals tried (check_reachable)
PROBE_STEPS = 24  # environment steps with seeded actions
PROBE_SEED = 0

_KEYS: dict[int, dict] = {}  # id(task) -> its key, while the task lives (a key costs a second or so)


def _jsonable(value):
    """A field's value as plain JSON (arrays and tuples as lists, dataclasses as dicts)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return repr(value)


def rounded(value) -> dict:
    """``value`` (numbers, any shape) as its shape and its numbers to :data:`SIGNIFICANT` digits."""
    a = np.asarray(value, dtype=np.float64)
    text = [f"{x:.{SIGNIFICANT - 1}e}" if np.isfinite(x) else repr(float(x)) for x in (a.ravel() + 0.0)]  # -0 -> 0
    return {"shape": list(a.shape), "values": text}


def _reachable(task: Task, goals: np.ndarray) -> bool:
    try:
        task.check_reachable(goals, "goals")
    except ScdpError:
        return False
    return True


def behaviour_probe(task: Task) -> dict[str, object]:
    """Each probe's output on seeded inputs (name -> numbers or verdicts), before hashing."""
    rng = stream_rng(TASK_KEY, PROBE_SEED)
    low, high = task.state_bounds()
    states = low + (high - low) * rng.random((PROBE_STATES, task.state_dim))
    box_low, box_high = task.workspace_low, task.workspace_high
    candidates = box_low + (box_high - box_low) * rng.random((PROBE_SCENES, 1, task.space_dim))
    demos, _ = generate_demos(task, PROBE_DEMOS, PROBE_SEED, progress=False)
    return {
        "nominal_start": rounded(task.nominal_start()),
        "start_state": rounded([task.start_state(rng) for _ in range(3)]),
        "state_bounds": rounded([low, high]),
        "task_space": rounded(task.task_space(states)),
        "sample_goals": rounded([task.sample_goals(rng, 2) for _ in range(PROBE_SCENES)]),
        "check_reachable": [_reachable(task, g) for g in candidates],
        "demos": {k: rounded(v) for k, v in (("state", demos.state), ("action", demos.action), ("goals", demos.goals),
                                             ("episode_ends", demos.episode_ends))},
        "env_steps": rounded(_stepped(task, rng)),
    }


def _stepped(task: Task, rng: np.random.Generator) -> np.ndarray:
    """The states of the task's environment from its nominal start, each action a seeded step of up
    to a tenth of the state box towards a random point inside it: (PROBE_STEPS + 1, state_dim)."""
    env = task.make_env()
    try:
        obs, _ = env.reset(options={"goals": task.layouts[0], "target": 0, "start_state": task.nominal_start()})
        low, high = task.state_bounds()
        states = [obs["state"]]
        for _ in range(PROBE_STEPS):
            toward = low + (high - low) * rng.random(task.state_dim)
            action = np.clip(states[-1] + 0.1 * (toward - states[-1]), low, high)
            obs, *_ = env.step(action)
            states.append(obs["state"])
        return np.array(states)
    finally:
        env.close()


def task_key(task: Task) -> dict:
    """``{"fields": {name: JSON value}, "probe": {probe name: SHA-256}}``, as JSON reads it back
    (computed once per task object)."""
    key = _KEYS.get(id(task))
    if key is None:
        fields = {f.name: _jsonable(getattr(task, f.name)) for f in dataclasses.fields(task)}
        probe = {name: digest(out) for name, out in behaviour_probe(task).items()}
        key = json.loads(json.dumps({"fields": fields, "probe": probe}))
        _KEYS[id(task)] = key
        weakref.finalize(task, _KEYS.pop, id(task), None)
    return key
