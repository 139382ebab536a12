"""LeRobot datasets (format v3: parquet files and ``meta/info.json``), read and written with pyarrow
alone, without the ``lerobot`` package (which needs Python >= 3.12 and another torch).

Layout (``meta/info.json`` holds the paths, the features, ``fps`` and ``codebase_version``)::

    meta/info.json
    meta/stats.json                               per feature: min, max, mean, std, count
    meta/tasks.parquet                            task_index, task
    meta/episodes/chunk-000/file-000.parquet      one row per episode: episode_index, length, tasks, where its rows are
    data/chunk-000/file-000.parquet               one row per frame: the features, timestamp, frame_index,
                                                  episode_index, index, task_index

``timestamp`` is relative to its episode (``frame_index / fps``), never absolute: readers that take
it as absolute offset every frame twice (lerobot issues #3513, #4524); a dataset written otherwise
is refused on import.

**Mapping to scdp's demos.** ``observation.state`` is the state and ``action`` the absolute next
state (the task's ``state_dim`` each; ``--state-feature``, ``--action-feature`` name others). The
goals come from a feature (``--goals-feature``: every goal's coordinates, flattened, read from an
episode's first frame; ``--target-feature``: the index of g*, default 0), or, without one, from the
task: g* is where the episode ends (its last state's task-space point) and one distractor is drawn
by the task's scene sampler (seeded per episode, so an import is repeatable). ``export_lerobot``
writes ``observation.goals`` and ``observation.target_index`` so that scdp's own exports map back
exactly.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from scdp.content import digest, file_sha256
from scdp.data.dataset import MIN_STEPS, DemoDataset
from scdp.data.scenes import DEMOS, stream_rng
from scdp.errors import ScdpError
from scdp.io import atomic_path, write_json
from scdp.tasks import Task, get_task

CODEBASE_VERSION = "v3.0"
STATE, ACTION, GOALS, TARGET = "observation.state", "action", "observation.goals", "observation.target_index"
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
EPISODES_FILE = "meta/episodes/chunk-000/file-000.parquet"
TASK_TEXT = "reach the target goal"
CHUNKS_SIZE = 1000  # files per chunk folder (LeRobot's default)
TIME_TOLERANCE = 1e-4  # s: a timestamp this far from frame_index / fps is not episode-relative
DEFAULT_FPS = 10.0


# -- writing -----------------------------------------------------------------------------------
def _stats(values: np.ndarray) -> dict:
    """LeRobot's per-feature statistics of (N, d) values: per dimension min, max, mean, std; the count."""
    v = np.asarray(values, dtype=np.float64).reshape(len(values), -1)
    return {"min": v.min(0).tolist(), "max": v.max(0).tolist(), "mean": v.mean(0).tolist(), "std": v.std(0).tolist(),
            "count": [len(v)]}


def _vector(dim: int, names: list[str]) -> dict:
    return {"dtype": "float32", "shape": [dim], "names": names}


def export_lerobot(dataset: DemoDataset, out, *, fps: float = DEFAULT_FPS, force: bool = False) -> Path:
    """Write ``dataset`` as a LeRobot v3 dataset in the folder ``out`` (written whole to a temporary
    folder, then renamed: nothing half-written); an existing ``out`` is replaced only with ``force``."""
    out = Path(out)
    if out.exists() and not force:
        raise ScdpError("--out", f"{out} exists; pass --force to replace it")
    if not 0.0 < fps <= 1000.0:
        raise ScdpError("--fps", f"must be above 0 and at most 1000 frames per second, got {fps}")
    task = dataset.task_object()
    n, k = dataset.num_steps, dataset.goals.shape[1]
    ends = np.asarray(dataset.episode_ends)
    starts = np.concatenate([[0], ends[:-1]])
    episode = np.repeat(np.arange(len(ends)), ends - starts)  # (N,)
    frame = np.arange(n) - starts[episode]
    target = np.asarray(dataset.target_index)[episode]
    goals = dataset.goals.reshape(n, -1).astype(np.float32)
    axes = "xyz"[:task.space_dim]
    features = {STATE: _vector(task.state_dim, list(task.state_names)),
                ACTION: _vector(task.state_dim, list(task.state_names)),
                GOALS: _vector(goals.shape[1], [f"goal{g}_{a}" for g in range(k) for a in axes]),
                TARGET: {"dtype": "int64", "shape": [1], "names": None},
                "timestamp": {"dtype": "float32", "shape": [1], "names": None},
                "frame_index": {"dtype": "int64", "shape": [1], "names": None},
                "episode_index": {"dtype": "int64", "shape": [1], "names": None},
                "index": {"dtype": "int64", "shape": [1], "names": None},
                "task_index": {"dtype": "int64", "shape": [1], "names": None}}
    columns = {STATE: dataset.state.astype(np.float32), ACTION: dataset.action.astype(np.float32), GOALS: goals,
               TARGET: target.astype(np.int64), "timestamp": (frame / fps).astype(np.float32),
               "frame_index": frame.astype(np.int64), "episode_index": episode.astype(np.int64),
               "index": np.arange(n, dtype=np.int64), "task_index": np.zeros(n, dtype=np.int64)}
    data = pa.table({name: (pa.array(list(v), type=pa.list_(pa.float32())) if v.ndim == 2 else pa.array(v))
                     for name, v in columns.items()})
    episodes = pa.table({"episode_index": np.arange(len(ends), dtype=np.int64),
                         "tasks": pa.array([[TASK_TEXT]] * len(ends), type=pa.list_(pa.string())),
                         "length": (ends - starts).astype(np.int64),
                         "data/chunk_index": np.zeros(len(ends), dtype=np.int64),
                         "data/file_index": np.zeros(len(ends), dtype=np.int64),
                         "dataset_from_index": starts.astype(np.int64), "dataset_to_index": ends.astype(np.int64),
                         "meta/episodes/chunk_index": np.zeros(len(ends), dtype=np.int64),
                         "meta/episodes/file_index": np.zeros(len(ends), dtype=np.int64)})
    info = {"codebase_version": CODEBASE_VERSION, "robot_type": task.name, "total_episodes": int(len(ends)),
            "total_frames": int(n), "total_tasks": 1, "chunks_size": CHUNKS_SIZE, "data_files_size_in_mb": 100,
            "video_files_size_in_mb": 500, "fps": float(fps), "splits": {"train": f"0:{len(ends)}"},
            "data_path": DATA_PATH, "video_path": None, "features": features,
            "scdp": {"task": dataset.task, "source": dataset.attrs.get("source", "scdp")}}
    stats = {name: _stats(v) for name, v in columns.items()}
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out, directory=True) as tmp:
        (tmp / "data" / "chunk-000").mkdir(parents=True)
        (tmp / "meta" / "episodes" / "chunk-000").mkdir(parents=True)
        pq.write_table(data, tmp / DATA_PATH.format(chunk_index=0, file_index=0))
        pq.write_table(episodes, tmp / EPISODES_FILE)
        pq.write_table(pa.table({"task_index": [0], "task": [TASK_TEXT]}), tmp / "meta" / "tasks.parquet")
        write_json(tmp / "meta" / "info.json", info)
        write_json(tmp / "meta" / "stats.json", stats)
    return out


# -- reading -----------------------------------------------------------------------------------
def read_info(root: Path) -> dict:
    """``meta/info.json`` of a v3 dataset; a v2.x dataset, or no dataset, is refused."""
    path = root / "meta" / "info.json"
    if not path.is_file():
        raise ScdpError("lerobot", f"{root} has no meta/info.json: not a LeRobot dataset")
    try:
        info = json.loads(path.read_text())
    except ValueError as exc:
        raise ScdpError("meta/info.json", f"not JSON ({exc})") from None
    version = str(info.get("codebase_version", ""))
    if not version.startswith("v3"):
        raise ScdpError("meta/info.json", f"codebase_version {version or 'missing'}: scdp reads LeRobot v3 datasets; "
                                          "convert a v2.x dataset with lerobot's v2.1 -> v3.0 converter first")
    if not isinstance(info.get("features"), dict) or not isinstance(info.get("fps"), (int, float)):
        raise ScdpError("meta/info.json", "needs 'features' (an object) and 'fps' (a number)")
    return info


def _feature(info: dict, name: str, dim: int | None, task: Task, what: str) -> None:
    """Refuse a feature the task cannot read, naming it and what was expected."""
    features = info["features"]
    if name not in features:
        visual = [f for f, spec in features.items() if isinstance(spec, dict) and spec.get("dtype") in ("video", "image")]
        hint = (f"; the dataset's observations are {', '.join(visual)} (images), and task {task.name!r} is "
                "low-dimensional") if visual and what == "state" else ""
        raise ScdpError(name, f"no such feature (the {what}; the dataset has {', '.join(sorted(features))}){hint}")
    shape = features[name].get("shape")
    if dim is not None and shape != [dim]:
        raise ScdpError(name, f"expected shape [{dim}] (task {task.name!r}'s {what}), got {shape}")


def _column(table: pa.Table, name: str) -> np.ndarray:
    column = table.column(name).combine_chunks()
    if pa.types.is_list(column.type) or pa.types.is_fixed_size_list(column.type):
        return np.asarray(column.flatten().to_numpy(zero_copy_only=False), dtype=np.float64).reshape(len(table), -1)
    return np.asarray(column.to_numpy(zero_copy_only=False))


def import_lerobot(path, task: Task | str, *, state: str = STATE, action: str = ACTION, goals: str | None = None,
                   target: str | None = None, goal_dim: int | None = None) -> DemoDataset:
    """A LeRobot v3 dataset's episodes as scdp demos (module docstring: the mapping)."""
    task = get_task(task)
    root = Path(path)
    info = read_info(root)
    _feature(info, state, task.state_dim, task, "state")
    _feature(info, action, task.state_dim, task, "action")
    goals = goals if goals is not None else (GOALS if GOALS in info["features"] else None)
    target = target if target is not None else (TARGET if goals == GOALS and TARGET in info["features"] else None)
    for name in (goals, target):
        if name is not None:
            _feature(info, name, None, task, "goals" if name == goals else "target")
    files = sorted((root / "data").glob("**/*.parquet"))
    if not files:
        raise ScdpError("data", f"{root} has no data/**/*.parquet files")
    wanted = [c for c in (state, action, goals, target, "timestamp", "frame_index", "episode_index") if c]
    try:
        table = pa.concat_tables([pq.read_table(f, columns=wanted) for f in files])
    except (pa.ArrowInvalid, KeyError) as exc:
        raise ScdpError("data", f"cannot read the columns {', '.join(wanted)} ({exc})") from None
    fps = float(info["fps"])
    cols = {name: _column(table, name) for name in wanted}
    episode, frame = cols["episode_index"].astype(np.int64).reshape(-1), cols["frame_index"].astype(np.int64).reshape(-1)
    order = np.lexsort((frame, episode))
    cols = {k: v[order] for k, v in cols.items()}
    episode, frame = episode[order], frame[order]
    timestamp = cols["timestamp"].astype(np.float64).reshape(-1)
    off = np.abs(timestamp - frame / fps)
    if np.any(off > TIME_TOLERANCE):
        i = int(np.argmax(off))
        raise ScdpError("timestamp", f"must be relative to its episode (frame_index / fps): episode {episode[i]} frame "
                                     f"{frame[i]} has {timestamp[i]:.4f} s, expected {frame[i] / fps:.4f} s (absolute "
                                     "times are offset twice by every reader)")
    goal_dim = task.space_dim if goal_dim is None else goal_dim
    episodes = []
    for e in np.unique(episode):
        rows = np.flatnonzero(episode == e)
        if not np.array_equal(frame[rows], np.arange(len(rows))):
            raise ScdpError("frame_index", f"episode {e} does not hold frames 0..{len(rows) - 1} once each")
        states, actions = cols[state][rows], cols[action][rows]
        field = f"episode {e}"
        if len(rows) < MIN_STEPS:
            raise ScdpError(field, f"has {len(rows)} frames; a demo needs at least {MIN_STEPS}")
        task.check_states(states, f"{field}: {state}", what="frame")
        task.check_states(actions, f"{field}: {action}", what="frame")
        if goals is not None:
            first = np.asarray(cols[goals][rows[0]], dtype=np.float64).reshape(-1)
            if first.size % goal_dim:
                raise ScdpError(goals, f"{first.size} values do not split into goals of {goal_dim} coordinates")
            g = task.validate_goals(first.reshape(-1, goal_dim), 0, field=f"{field}: {goals}")
            t = int(np.asarray(cols[target][rows[0]]).reshape(-1)[0]) if target is not None else 0
            if not 0 <= t < len(g):
                raise ScdpError(target, f"{field}: index {t} is not one of its {len(g)} goals")
        else:  # from the task: g* where the episode ends, one distractor from the task's sampler
            end = task.task_space(states[-1])
            rng = stream_rng(DEMOS, int(e), "lerobot")
            g = np.stack([end, task.sample_goals(rng, 2)[1]])
            t = 0
            g = task.validate_goals(g, 0, field=f"{field}: goals from the task")
        episodes.append({"state": states, "action": actions, "goals": g, "target": t})
    attrs = {"source": f"lerobot:{root.name}", "codebase_version": info["codebase_version"],
             "info_sha256": file_sha256(root / "meta" / "info.json"),
             "mapping": {"state": state, "action": action, "goals": goals or "task", "target": target},
             "mapping_digest": digest([state, action, goals, target, goal_dim])}
    return DemoDataset.from_episodes(task.name, episodes, attrs)
