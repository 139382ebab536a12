"""scdp demos written as a LeRobot v3 dataset that LeRobot's own reader, tools and policies take as theirs.

What LeRobot needs, and where this writer puts it (:mod:`scdp.data.lerobot` reads it back)::

    meta/info.json          codebase_version, robot_type, an integer fps, the features with their names
    meta/tasks.parquet      the task texts as the table's pandas index, task_index its column (LeRobot
                            reads ``tasks.iloc[i].name`` as the text of task i)
    meta/episodes/...       per episode: tasks, length, where its frames are, and its statistics
                            (``stats/<feature>/<stat>``: LeRobot rebuilds stats.json from them after an edit)
    meta/stats.json         every feature's statistics with LeRobot's quantiles (:mod:`scdp.data.lerobot_stats`)
    meta/scdp.json          scdp's provenance, in a file of its own (LeRobot warns on unknown info.json keys)
    data/chunk-000/file-000.parquet

The goals go in ``observation.environment_state``, the one observation LeRobot's policies read as the
environment: g* first, then the others in scdp's order. ``target_index`` (not an observation, so no policy reads
it) says where g* stood among them, so scdp's import puts every goal back where it was.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from scdp.data import lerobot as layout
from scdp.data.dataset import DemoDataset
from scdp.data.lerobot_stats import STAT_KEYS, as_json, feature_stats, pooled_stats
from scdp.errors import ScdpError
from scdp.io import atomic_path, write_json

INDEX_FEATURES = ("timestamp", "frame_index", "episode_index", "index", "task_index")  # every LeRobot dataset's own


def goals_target_first(goals: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Per frame, the goals (N, K, G) reordered g* first, the others in their order, flattened: (N, K G)."""
    n, k = goals.shape[:2]
    order = np.array([[t, *(j for j in range(k) if j != t)] for t in range(k)])[target]  # (N, K)
    return np.take_along_axis(goals, order[:, :, None], axis=1).reshape(n, -1)


def task_table(texts: list[str]) -> pa.Table:
    """``meta/tasks.parquet`` as pandas writes LeRobot's: ``task_index``, then the texts as the frame's index (the
    pandas metadata names the index column, so ``pandas.read_parquet`` gives the texts back as the index)."""
    pandas = {"index_columns": ["__index_level_0__"], "column_indexes": [],
              "columns": [{"name": "task_index", "field_name": "task_index", "pandas_type": "int64",
                           "numpy_type": "int64", "metadata": None},
                          {"name": None, "field_name": "__index_level_0__", "pandas_type": "unicode",
                           "numpy_type": "object", "metadata": None}],
              "creator": {"library": "pyarrow", "version": pa.__version__}, "pandas_version": "2.2.3"}
    schema = pa.schema([("task_index", pa.int64()), ("__index_level_0__", pa.string())],
                       metadata={b"pandas": json.dumps(pandas).encode()})
    return pa.table({"task_index": np.arange(len(texts), dtype=np.int64), "__index_level_0__": texts}, schema=schema)


def _list_type(values: np.ndarray, stat: str) -> pa.DataType:
    whole = stat == "count" or (stat in ("min", "max") and np.issubdtype(values.dtype, np.integer))
    return pa.list_(pa.int64() if whole else pa.float64())


def episode_table(columns: dict[str, np.ndarray], starts: np.ndarray, ends: np.ndarray, texts: list[str],
                  episode_tasks: np.ndarray) -> tuple[pa.Table, dict]:
    """``meta/episodes`` with LeRobot's columns, in its order, and the pooled ``stats.json`` of ``columns``."""
    e = len(ends)
    table = {"episode_index": pa.array(np.arange(e, dtype=np.int64)),
             "tasks": pa.array([[texts[i]] for i in episode_tasks], type=pa.list_(pa.string())),
             "length": pa.array((ends - starts).astype(np.int64)),
             "data/chunk_index": pa.array(np.zeros(e, dtype=np.int64)),
             "data/file_index": pa.array(np.zeros(e, dtype=np.int64)),
             "dataset_from_index": pa.array(starts.astype(np.int64)), "dataset_to_index": pa.array(ends.astype(np.int64))}
    pooled = {}
    for name, values in columns.items():
        per_episode = [feature_stats(values[a:b]) for a, b in zip(starts, ends)]
        pooled[name] = as_json(pooled_stats(per_episode))
        for stat in STAT_KEYS:
            cells = [np.asarray(s[stat]) for s in per_episode]
            table[f"stats/{name}/{stat}"] = pa.array([c.tolist() for c in cells], type=_list_type(cells[0], stat))
    table["meta/episodes/chunk_index"] = pa.array(np.zeros(e, dtype=np.int64))
    table["meta/episodes/file_index"] = pa.array(np.zeros(e, dtype=np.int64))
    return pa.table(table), pooled


def _vector(names: list[str]) -> dict:
    return {"dtype": "float32", "shape": [len(names)], "names": list(names)}


def _scalar(dtype: str) -> dict:
    return {"dtype": dtype, "shape": [1], "names": None}


def frame_columns(dataset: DemoDataset, fps: float, episode_tasks: np.ndarray, names: dict) -> tuple[dict, dict]:
    """Every frame's columns (N, ...) and their feature specs, in LeRobot's terms (the module docstring)."""
    task, n, k = dataset.task_object(), dataset.num_steps, dataset.goals.shape[1]
    ends = np.asarray(dataset.episode_ends, dtype=np.int64)
    starts = np.concatenate([[0], ends[:-1]])
    episode = np.repeat(np.arange(len(ends)), ends - starts)  # (N,)
    frame = np.arange(n) - starts[episode]
    target = np.asarray(dataset.target_index, dtype=np.int64)[episode]
    axes = "xyz"[:task.space_dim]
    goal_names = [f"{'target' if g == 0 else f'other{g}'}_{a}" for g in range(k) for a in axes]
    kept = {key: names.get(key) if len(names.get(key) or ()) == len(default) else list(default)  # a source's names
            for key, default in ((layout.STATE, task.state_names), (layout.ACTION, task.state_names),
                                 (layout.ENV_STATE, goal_names))}
    features = {**{key: _vector(value) for key, value in kept.items()},
                layout.TARGET_SLOT: _scalar("int64"), "timestamp": _scalar("float32"),
                **{name: _scalar("int64") for name in INDEX_FEATURES[1:]}}
    columns = {layout.STATE: dataset.state.astype(np.float32), layout.ACTION: dataset.action.astype(np.float32),
               layout.ENV_STATE: goals_target_first(dataset.goals, target).astype(np.float32),
               layout.TARGET_SLOT: target, "timestamp": (frame / fps).astype(np.float32),
               "frame_index": frame.astype(np.int64), "episode_index": episode.astype(np.int64),
               "index": np.arange(n, dtype=np.int64), "task_index": episode_tasks[episode]}
    return columns, features


def export_lerobot(dataset: DemoDataset, out, *, fps: float | None = None, task_text: str | None = None,
                   robot_type: str | None = None, force: bool = False) -> Path:
    """Write ``dataset`` as a LeRobot v3 dataset in the folder ``out`` (written whole to a temporary folder, then
    renamed: nothing half-written); an existing ``out`` is replaced only with ``force``. ``fps``, ``task_text``
    and ``robot_type`` default to what an imported dataset came with (:func:`scdp.data.lerobot.source_metadata`),
    else 10 fps, :data:`scdp.data.lerobot.TASK_TEXT` and the task's name."""
    out = Path(out)
    if out.exists() and not force:
        raise ScdpError("--out", f"{out} exists; pass --force to replace it")
    source = layout.source_metadata(dataset)
    fps = layout.check_fps(source.get("fps", layout.DEFAULT_FPS) if fps is None else fps, "--fps")
    for field, value in (("--task-text", task_text), ("--robot-type", robot_type)):
        if value is not None and not value.strip():
            raise ScdpError(field, "must not be empty")
    per_episode = [task_text] * dataset.num_episodes if task_text is not None else (
        source.get("tasks") or [layout.TASK_TEXT] * dataset.num_episodes)
    texts = list(dict.fromkeys(per_episode))  # the distinct texts, first seen first
    episode_tasks = np.array([texts.index(t) for t in per_episode], dtype=np.int64)
    columns, features = frame_columns(dataset, fps, episode_tasks, source.get("names", {}))
    ends = np.asarray(dataset.episode_ends, dtype=np.int64)
    episodes, stats = episode_table(columns, np.concatenate([[0], ends[:-1]]), ends, texts, episode_tasks)
    info = {"codebase_version": layout.CODEBASE_VERSION,
            "robot_type": robot_type or source.get("robot_type") or dataset.task,
            "total_episodes": int(len(ends)), "total_frames": int(dataset.num_steps), "total_tasks": len(texts),
            "chunks_size": layout.CHUNKS_SIZE, "data_files_size_in_mb": 100, "video_files_size_in_mb": 200,
            "fps": int(fps) if fps.is_integer() else fps, "splits": {"train": f"0:{len(ends)}"},
            "data_path": layout.DATA_PATH, "video_path": None, "features": features}
    data = pa.table({name: (pa.array(list(v), type=pa.list_(pa.float32())) if v.ndim == 2 else pa.array(v))
                     for name, v in columns.items()})
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out, directory=True) as tmp:
        (tmp / "data" / "chunk-000").mkdir(parents=True)
        (tmp / "meta" / "episodes" / "chunk-000").mkdir(parents=True)
        pq.write_table(data, tmp / layout.DATA_PATH.format(chunk_index=0, file_index=0))
        pq.write_table(episodes, tmp / layout.EPISODES_FILE)
        pq.write_table(task_table(texts), tmp / layout.TASKS_FILE)
        write_json(tmp / "meta" / "info.json", info)
        write_json(tmp / "meta" / "stats.json", stats)
        write_json(tmp / layout.PROVENANCE_FILE, {"task": dataset.task, "source": dataset.attrs.get("source", "scdp")})
    return out
