"""Import robomimic-style HDF5 demonstrations (the authors' format).

Expected layout::

    data/demo_<k>/states       (T, state_dim)
    data/demo_<k>/actions      (T, state_dim)   the next state
    data/demo_<k>/obs/object   (T, n_goals * goal_dim) or (n_goals * goal_dim,)  g* first, then g-

    data/demo_<k>/dones        (T,)  optional; steps after the first true one are dropped

Goals may be given with fewer coordinates than the task's space (Block Reach goals in xy
get z = 0.1); they are read from the first step of each demo. Demos are imported in
numeric order of ``k``.

The file is not trusted. Actions are absolute next states, so an action farther from its
state than the robot can move in one control step (:meth:`Task.reach_used` > 1, from the
datasheet speed limits) is not motion: typically an all-zero "done" sentinel at a demo's end.
So is an action more than one step from the state that follows it. Such steps are dropped
from the end of a demo and counted (at most :data:`MAX_TRAILING_SHARE` of it); anywhere
else they are refused.
A demo left with fewer than :data:`MIN_STEPS` steps is refused, as is a state outside the task's
bounds (:meth:`Task.state_bounds`). Only objects inside the file are read: an external link, or a
soft link that dangles or loops, is refused by name.
"""

from __future__ import annotations

import re
from pathlib import Path

import h5py
import numpy as np

from scdp.data.dataset import MIN_STEPS, DemoDataset
from scdp.errors import ScdpError
from scdp.tasks import Task, get_task

MAX_TRAILING_SHARE = 0.25  # out-of-reach steps dropped from a demo's end: more is broken data, not a sentinel


def import_robomimic(path, task: Task, *, goal_dim: int | None = None) -> DemoDataset:
    """Read an HDF5 file into a :class:`DemoDataset` (g* is goal 0 of every demo).

    ``goal_dim`` is the number of coordinates per goal in ``obs/object``; by default the
    task's space dimension. Steps that cannot be real motion are dropped from the end of a demo
    (see the module docstring); their count is in ``attrs["dropped_steps"]``, and the CLI warns.
    """
    task = get_task(task)
    path = Path(path)
    if not path.exists():
        raise ScdpError("hdf5", f"{path} does not exist")
    goal_dim = task.space_dim if goal_dim is None else goal_dim
    if isinstance(goal_dim, bool) or not isinstance(goal_dim, int) or not 1 <= goal_dim <= task.space_dim:
        raise ScdpError("--goal-dim", f"must be an integer from 1 to {task.space_dim} for task {task.name!r}, got {goal_dim!r}")
    episodes, dropped = [], {}
    try:
        with h5py.File(path, "r") as f:
            data = _node(f, "data", "hdf5") if f.get("data", getlink=True) is not None else None
            if not isinstance(data, h5py.Group):
                raise ScdpError("hdf5", f"{path} has no 'data' group")
            names = sorted((n for n in data if re.fullmatch(r"demo_\d+", n)), key=lambda n: int(n[5:]))
            if not names:
                raise ScdpError("hdf5", f"{path} has no data/demo_<k> groups")
            for name in names:
                episode, n_dropped = _read_demo(_node(data, name, f"data/{name}"), f"data/{name}", task, goal_dim)
                if episodes and len(episode["goals"]) != len(episodes[0]["goals"]):  # one goal count per dataset
                    raise ScdpError(f"data/{name}/obs/object", f"holds {len(episode['goals'])} goals, data/{names[0]} "
                                                               f"{len(episodes[0]['goals'])}; a dataset has one goal count")
                episodes.append(episode)
                if n_dropped:
                    dropped[name] = n_dropped
    except OSError as exc:
        raise ScdpError("hdf5", f"{path} is not a readable HDF5 file ({exc})") from None
    attrs = {"source": f"robomimic:{path.name}", "dropped_steps": int(sum(dropped.values())),
             "demos_with_dropped_steps": len(dropped)}
    return DemoDataset.from_episodes(task.name, episodes, attrs)


def _read_demo(demo, field: str, task: Task, goal_dim: int) -> tuple[dict, int]:
    """One demo group -> (episode, steps dropped from its end)."""
    if not isinstance(demo, h5py.Group):
        raise ScdpError(field, "expected a group holding states, actions and obs/object")
    states = _array(demo, "states", field)
    actions = _array(demo, "actions", field)
    obj = _array(demo, "obs/object", field)
    if states.ndim != 2 or states.shape[1] != task.state_dim:
        raise ScdpError(f"{field}/states", f"expected (T, {task.state_dim}) for task {task.name!r}, got {states.shape}")
    if actions.shape != states.shape:
        raise ScdpError(f"{field}/actions", f"expected {states.shape} like the states, got {actions.shape}")
    if obj.ndim not in (1, 2):
        raise ScdpError(f"{field}/obs/object", f"expected (T, n_goals * {goal_dim}) or (n_goals * {goal_dim},), got {obj.shape}")
    first = obj[0] if obj.ndim == 2 else obj
    if first.size % goal_dim:
        raise ScdpError(f"{field}/obs/object", f"{first.size} values do not split into goals of {goal_dim}")
    goals = task.validate_goals(first.reshape(-1, goal_dim), 0, field=f"{field}/obs/object")
    for key, arr in (("states", states), ("actions", actions)):
        if not np.all(np.isfinite(arr)):
            raise ScdpError(f"{field}/{key}", "contains NaN or inf")
    dones = None
    if demo.get("dones", getlink=True) is not None:
        dones = _array(demo, "dones", field).reshape(-1)
        if len(dones) != len(states):
            raise ScdpError(f"{field}/dones", f"has {len(dones)} entries for {len(states)} steps")
    # a 1e30 state is a bad state, not an out-of-reach action (steps after 'dones' are dropped unread)
    last = int(np.flatnonzero(dones)[0]) + 1 if dones is not None and np.any(dones) else len(states)
    task.check_states(states[:last], f"{field}/states", what="step")
    keep = _usable_steps(task, field, states, actions, dones)
    episode = {"state": states[:keep], "action": actions[:keep], "goals": goals, "target": 0}
    return episode, len(states) - keep


def _node(group, key: str, field: str):
    """``group[key]`` (``key`` may hold ``/``), following only links that resolve inside the file:
    an external link, a dangling or circular soft link, or an object of another file is refused."""
    node = group
    for part in key.split("/"):
        link = node.get(part, getlink=True) if isinstance(node, h5py.Group) else None
        if link is None:
            raise ScdpError(field, "missing")
        if isinstance(link, h5py.ExternalLink):
            raise ScdpError(field, "is a link to another file; only objects inside this file are read")
        try:
            node = node[part]
        except (KeyError, RuntimeError, ValueError):
            raise ScdpError(field, "is a link that does not resolve inside the file (dangling or circular)") from None
        if node.file.filename != group.file.filename:
            raise ScdpError(field, "resolves to an object of another file; only objects inside this file are read")
    return node


def _array(demo, key: str, field: str) -> np.ndarray:
    """A non-empty numeric dataset of the demo group as float64."""
    node = _node(demo, key, f"{field}/{key}")
    if not isinstance(node, h5py.Dataset):
        raise ScdpError(f"{field}/{key}", "expected a dataset, found a group")
    try:
        arr = np.asarray(node[()], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ScdpError(f"{field}/{key}", f"not numeric ({exc})") from None
    if arr.size == 0:
        raise ScdpError(f"{field}/{key}", "is empty")
    return arr


def _usable_steps(task: Task, field: str, states, actions, dones) -> int:
    """How many leading steps of a demo are real motion.

    Steps after the first ``done`` go, then trailing steps whose action is out of the robot's
    one-step reach (terminal sentinels). An out-of-reach step anywhere else is refused: dropping
    it would splice the demo.
    """
    n = len(states)
    if dones is not None and np.any(dones):
        n = int(np.flatnonzero(dones)[0]) + 1
    reach = task.reach_used(states[:n], actions[:n])
    # an action is also the next state: it must lie within one step of where the robot went
    reach[:n - 1] = np.maximum(reach[:n - 1], task.reach_used(states[1:n], actions[:n - 1]))
    before = n
    while n and reach[n - 1] > 1.0:
        n -= 1
    if before - n > MAX_TRAILING_SHARE * before:
        raise ScdpError(f"{field}/actions", f"the last {before - n} of {before} steps are beyond the robot's one-step reach; "
                                            "that is not a terminal sentinel, so they cannot be dropped safely")
    if np.any(reach[:n] > 1.0):
        t = int(np.flatnonzero(reach[:n] > 1.0)[0])
        raise ScdpError(f"{field}/actions", f"step {t} of {len(states)} commands {reach[t]:.1f}x what the robot can move "
                                            f"in {task.control_dt} s; it is not at the demo's end, so it cannot be dropped safely")
    if n < MIN_STEPS:
        raise ScdpError(field, f"has {n} usable step(s) of {len(states)}; a demo needs at least {MIN_STEPS}")
    return n
