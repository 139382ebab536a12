"""Demonstrations in memory and in a zarr replay buffer.

On disk (a zarr group, Diffusion Policy's replay-buffer layout)::

    data/state   (N, state_dim)        float32   all episodes concatenated
    data/action  (N, state_dim)        float32   the next state, absolute
    data/goal    (N, space_dim)        float32   g* at each step
    data/goals   (N, n_goals, space_dim) float32 every goal at each step (g* included)
    meta/episode_ends   (E,)  int64   exclusive end index of each episode
    meta/target_index   (E,)  int64   which row of ``goals`` is g*
    attrs["scdp"]       JSON: format version, task, seed, generator settings, ...
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import zarr

from scdp.errors import ScdpError
from scdp.io import atomic_path, check_output_path
from scdp.tasks import Task, find_task, get_task, task_reference

FORMAT_VERSION = 1
MIN_STEPS = 2  # steps an episode needs: one step teaches no path (the importer refuses shorter demos too)
_DATA_KEYS = ("state", "action", "goal", "goals")


@dataclass
class DemoDataset:
    """Episodes of (state, action) pairs with their scenes, stored flat with episode ends."""

    task: str
    state: np.ndarray
    action: np.ndarray
    goal: np.ndarray
    goals: np.ndarray
    episode_ends: np.ndarray
    target_index: np.ndarray
    attrs: dict = field(default_factory=dict)

    def __post_init__(self):
        """Refuse anything a policy could not learn from: every check names its array."""
        task = find_task(self.task)  # a task not loaded in this process: its name is all that is checked
        n = len(self.state)
        for key in _DATA_KEYS:
            if len(getattr(self, key)) != n:
                raise ScdpError(f"data/{key}", f"has {len(getattr(self, key))} rows, expected {n}")
            if not np.issubdtype(np.asarray(getattr(self, key)).dtype, np.number):
                raise ScdpError(f"data/{key}", "is not numeric")
            if not np.all(np.isfinite(getattr(self, key))):
                raise ScdpError(f"data/{key}", "holds NaN or inf values")
        ends = np.asarray(self.episode_ends)
        if not len(ends):
            raise ScdpError("meta/episode_ends", "the dataset holds no episodes")
        if not np.issubdtype(ends.dtype, np.integer) or np.any(np.diff(ends) <= 0) or ends[0] <= 0 or ends[-1] != n:
            raise ScdpError("meta/episode_ends", "must be strictly increasing integers ending at the number of steps")
        targets = np.asarray(self.target_index)
        if len(targets) != len(ends):
            raise ScdpError("meta/target_index", f"has {len(targets)} entries for {len(ends)} episodes")
        state, goals = np.asarray(self.state), np.asarray(self.goals)
        if state.ndim != 2 or np.shape(self.action) != state.shape:
            raise ScdpError("data/action", f"shape {np.shape(self.action)} does not match data/state {state.shape}")
        if goals.ndim != 3 or goals.shape[1] < 2:
            raise ScdpError("data/goals", f"needs (steps, goals >= 2, dims), got shape {goals.shape}")
        if np.shape(self.goal) != (n, goals.shape[2]):
            raise ScdpError("data/goal", f"shape {np.shape(self.goal)} does not match data/goals {goals.shape}")
        if not np.issubdtype(targets.dtype, np.integer) or targets.min() < 0 or targets.max() >= goals.shape[1]:
            raise ScdpError("meta/target_index", f"must be integers in 0..{goals.shape[1] - 1}, got {targets.min()}..{targets.max()}")
        if task is not None and (state.shape[1] != task.state_dim or goals.shape[2] != task.space_dim):
            raise ScdpError("task", f"{task.name!r} has {task.state_dim}-D states and {task.space_dim}-D goals; "
                                    f"the data has {state.shape[1]}-D states and {goals.shape[2]}-D goals")
        short = np.flatnonzero(np.diff(np.concatenate([[0], ends])) < MIN_STEPS)
        if len(short):
            k = int(short[0])
            raise ScdpError("meta/episode_ends", f"episode {k} has {int(ends[k] - (ends[k - 1] if k else 0))} step(s); "
                                                 f"a demo needs at least {MIN_STEPS} (one step teaches no path)")
        if task is not None:  # a state the robot cannot be in is named as such, before any reach is computed
            low, high = task.state_bounds()
            outside = (state < low) | (state > high)
            if outside.any():
                t, j = (int(i[0]) for i in np.nonzero(outside))
                raise ScdpError("data/state", f"step {t} (episode {int(np.searchsorted(ends, t, side='right'))}): "
                                              f"{task.state_names[j]} = {state[t, j]:.4g} is outside the {task.name} "
                                              f"bounds {low[j]:.4g}..{high[j]:.4g}")
        if task is not None:  # actions are next states: one beyond the robot's reach is no motion
            reach = task.reach_used(state, self.action)
            if np.any(reach > 1.0):
                t = int(np.argmax(reach > 1.0))
                raise ScdpError("data/action", f"step {t} (episode {int(np.searchsorted(ends, t, side='right'))}) asks for "
                                               f"{reach[t]:.3g}x what the robot can move in one control step; "
                                               "actions must be the next state")
        self.episode_ends = ends.astype(np.int64)
        self.target_index = targets.astype(np.int64)

    # -- construction ----------------------------------------------------------------------
    @classmethod
    def from_episodes(cls, task: str, episodes: list[dict], attrs: dict | None = None) -> "DemoDataset":
        """Build from dicts with ``state`` (T, S), ``action`` (T, S), ``goals`` (K, d), ``target``."""
        if not episodes:
            raise ScdpError("episodes", "no episodes to store")
        lengths = [len(ep["state"]) for ep in episodes]
        goals = np.concatenate([np.repeat(np.asarray(ep["goals"])[None], n, 0) for ep, n in zip(episodes, lengths)])
        targets = np.array([ep["target"] for ep in episodes], dtype=np.int64)
        goal = np.concatenate([np.repeat(np.asarray(ep["goals"])[ep["target"]][None], n, 0) for ep, n in zip(episodes, lengths)])
        return cls(
            task=task,
            state=np.concatenate([ep["state"] for ep in episodes]).astype(np.float32),
            action=np.concatenate([ep["action"] for ep in episodes]).astype(np.float32),
            goal=goal.astype(np.float32),
            goals=goals.astype(np.float32),
            episode_ends=np.cumsum(lengths),
            target_index=targets,
            attrs=dict(attrs or {}),
        )

    def fingerprint(self) -> str:
        """SHA-256 of the task and every array: two datasets with the same fingerprint hold the same data."""
        digest = hashlib.sha256(self.task.encode())
        for key in (*_DATA_KEYS, "episode_ends", "target_index"):
            a = np.ascontiguousarray(getattr(self, key))
            digest.update(f"{key}{a.dtype}{a.shape}".encode())
            digest.update(a.tobytes())
        return digest.hexdigest()

    # -- access ----------------------------------------------------------------------------
    @property
    def num_episodes(self) -> int:
        return len(self.episode_ends)

    @property
    def num_steps(self) -> int:
        return len(self.state)

    def episode_bounds(self, i: int) -> tuple[int, int]:
        start = 0 if i == 0 else int(self.episode_ends[i - 1])
        return start, int(self.episode_ends[i])

    def episode(self, i: int) -> dict:
        """One episode: ``state``, ``action`` (T, S), ``goals`` (K, d) and ``target``."""
        a, b = self.episode_bounds(i)
        return {
            "state": self.state[a:b].astype(np.float64),
            "action": self.action[a:b].astype(np.float64),
            "goals": self.goals[a].astype(np.float64),
            "target": int(self.target_index[i]),
        }

    def episode_lengths(self) -> np.ndarray:
        return np.diff(np.concatenate([[0], self.episode_ends]))

    def subset(self, indices) -> "DemoDataset":
        """A new dataset holding the given episodes, in the given order."""
        eps = [self.episode(int(i)) for i in indices]
        attrs = dict(self.attrs, subset_of=self.attrs.get("source", "dataset"), subset_size=len(eps))
        return DemoDataset.from_episodes(self.task, eps, attrs)

    # -- zarr ------------------------------------------------------------------------------
    def save(self, path, *, force: bool = False) -> Path:
        """Write the zarr group atomically (temporary folder, then rename)."""
        path = check_output_path(path, force=force)
        with atomic_path(path, directory=True) as tmp:
            root = zarr.open_group(str(tmp), mode="w")
            for key in _DATA_KEYS:
                _write(root, f"data/{key}", getattr(self, key))
            _write(root, "meta/episode_ends", self.episode_ends)
            _write(root, "meta/target_index", self.target_index)
            reference = task_reference(self.task)  # a task of your own: how a new process finds it
            reference = {"task_reference": reference} if reference != self.task else {}
            root.attrs["scdp"] = {"format_version": FORMAT_VERSION, "task": self.task, **_jsonable(self.attrs), **reference}
        return path

    def task_object(self) -> Task:
        """The task the demonstrations belong to: found by the reference stored with them (a task of
        your own: its module:OBJECT, so a new process finds it), else by name."""
        return get_task(self.attrs.get("task_reference", self.task))

    @classmethod
    def load(cls, path) -> "DemoDataset":
        """Read a zarr replay buffer written by :meth:`save`; raises ScdpError if it is not one."""
        path = Path(path)
        if not path.exists():
            raise ScdpError("dataset", f"{path} does not exist")
        try:
            root = zarr.open_group(str(path), mode="r")
            meta = dict(root.attrs.get("scdp", {}))
            arrays = {key: np.asarray(root[f"data/{key}"][:]) for key in _DATA_KEYS}
            ends = np.asarray(root["meta/episode_ends"][:])
            targets = np.asarray(root["meta/target_index"][:])
        except ScdpError:
            raise
        except Exception as exc:  # zarr raises many types for a damaged store
            raise ScdpError("dataset", f"{path} is not a readable scdp zarr dataset ({type(exc).__name__}: {exc})") from None
        if meta.get("format_version") != FORMAT_VERSION or "task" not in meta:
            raise ScdpError("dataset", f"{path} has no scdp metadata of format version {FORMAT_VERSION}")
        task = meta.pop("task")
        meta.pop("format_version")
        return cls(task=task, episode_ends=ends, target_index=targets, attrs=meta, **arrays)


def _write(root, name: str, data: np.ndarray) -> None:
    data = np.ascontiguousarray(data)
    if hasattr(root, "create_array"):  # zarr >= 3
        root.create_array(name, data=data)
    else:  # zarr 2
        root.create_dataset(name, data=data)


def _jsonable(obj):
    """Numpy scalars/arrays to plain JSON types."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj
