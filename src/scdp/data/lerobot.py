"""LeRobot datasets (format v3: parquet files and ``meta/info.json``) read into scdp's demos, with pyarrow
alone, without the ``lerobot`` package (which needs Python >= 3.12 and another torch);
:mod:`scdp.data.lerobot_export` writes them.

Layout (``meta/info.json`` holds the paths, the features, ``fps`` and ``codebase_version``)::

    meta/info.json
    meta/stats.json                               per feature: min, max, mean, std, count, quantiles
    meta/tasks.parquet                            task_index; the task texts as its pandas index
    meta/episodes/chunk-000/file-000.parquet      one row per episode: episode_index, tasks, length, where its
                                                  rows are, its statistics
    data/chunk-000/file-000.parquet               one row per frame: the features, timestamp, frame_index,
                                                  episode_index, index, task_index

``timestamp`` is relative to its episode (``frame_index / fps``), never absolute: readers that take
it as absolute offset every frame twice (lerobot issues #3513, #4524); a dataset written otherwise
is refused on import.

**Mapping to scdp's demos.** ``observation.state`` is the state and ``action`` the absolute next state (the
task's ``state_dim`` each; ``--state-feature``, ``--action-feature`` name others; ``action_from="next-state"``
builds each action from the next frame's state, for recordings of states only or of velocity commands). The
goals come from a feature (``--goals-feature``, default ``observation.environment_state`` where the dataset has
it: every goal's coordinates, flattened, g* first unless ``--target-feature`` names the index of g*; read from an
episode's first frame), or, without one, from the task: g* is where the episode ends (its last state's
task-space point) and one distractor is drawn by the task's scene sampler (seeded per episode, so an import is
repeatable). scdp's exports add ``target_index``, where g* stood among the goals, so they map back exactly.

Every broken dataset is refused with one line that names its cause (:class:`~scdp.errors.ScdpError`): the
types of ``meta/info.json``, ``fps``, a missing, ragged or empty column, a non-finite or non-integer index, a
column named twice.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from scdp.content import digest, file_sha256
from scdp.data.dataset import MIN_STEPS, DemoDataset
from scdp.data.scenes import DEMOS, stream_rng
from scdp.errors import ScdpError
from scdp.tasks import Task, get_task

CODEBASE_VERSION = "v3.0"
STATE, ACTION, ENV_STATE = "observation.state", "action", "observation.environment_state"
TARGET_SLOT = "target_index"  # scdp's exports: where g* stood among the goals (not an observation: no policy reads it)
GOALS, TARGET = "observation.goals", "observation.target_index"  # the goals as scdp exported them before
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
EPISODES_FILE = "meta/episodes/chunk-000/file-000.parquet"
TASKS_FILE = "meta/tasks.parquet"
PROVENANCE_FILE = "meta/scdp.json"
TASK_TEXT = "reach the target goal"
CHUNKS_SIZE = 1000  # files per chunk folder (LeRobot's default)
TIME_TOLERANCE = 1e-4  # s: a timestamp this far from frame_index / fps is not episode-relative
DEFAULT_FPS = 10
MAX_FPS = 1000
ACTION_FROM = ("feature", "next-state")  # where an imported action comes from
NEXT_STATE_HINT = ("; a recording of velocity commands (e.g. cmd_vel) or of states only imports with "
                   "--action-from next-state (each action the next frame's state)")


def check_fps(value, field: str) -> float:
    """``value`` as frames per second: a number above 0 and at most :data:`MAX_FPS` (not a bool, not NaN)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise ScdpError(field, f"must be a number of frames per second, got {json.dumps(value)}")
    if not 0 < value <= MAX_FPS:
        raise ScdpError(field, f"must be above 0 and at most {MAX_FPS} frames per second, got {value:g}")
    return float(value)


def source_metadata(dataset: DemoDataset) -> dict:
    """What an imported dataset kept of its LeRobot source (fps, robot_type, feature names, each episode's task
    text), for its export; {} for scdp's own demos. Task texts of another episode count (a subset) are dropped."""
    kept = dict(dataset.attrs.get("lerobot") or {})
    if len(kept.get("tasks") or []) != dataset.num_episodes:
        kept.pop("tasks", None)
    return kept


def read_info(root) -> dict:
    """``meta/info.json`` of a v3 dataset, its types checked; a v2.x dataset, or no dataset, is refused."""
    root = Path(root)
    path = root / "meta" / "info.json"
    if not path.is_file():
        raise ScdpError("lerobot", f"{root} has no meta/info.json: not a LeRobot dataset")
    try:
        info = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as exc:
        raise ScdpError("meta/info.json", f"not JSON ({exc})") from None
    if not isinstance(info, dict):
        raise ScdpError("meta/info.json", f"must be a JSON object, got a {type(info).__name__}")
    version = str(info.get("codebase_version", ""))
    if not version.startswith("v3"):
        raise ScdpError("meta/info.json", f"codebase_version {version or 'missing'}: scdp reads LeRobot v3 datasets; "
                                          "convert a v2.x dataset with lerobot's v2.1 -> v3.0 converter first")
    features = info.get("features")
    if not isinstance(features, dict):
        raise ScdpError("meta/info.json: features", f"must be an object of feature specs, got {json.dumps(features)}")
    for name, spec in features.items():
        if not isinstance(spec, dict) or not isinstance(spec.get("shape"), list):
            raise ScdpError(f"meta/info.json: features: {name}", "must be an object with a 'shape' list "
                                                                  f"(and 'dtype', 'names'), got {json.dumps(spec)}")
    if "fps" not in info:
        raise ScdpError("meta/info.json: fps", "missing (the frames per second the timestamps count in)")
    check_fps(info["fps"], "meta/info.json: fps")
    return info


def _feature(info: dict, name: str, dim: int | None, task: Task, what: str, hint: str = "") -> None:
    """Refuse a feature the task cannot read, naming it and what was expected."""
    features = info["features"]
    if name not in features:
        visual = [f for f, spec in features.items() if spec.get("dtype") in ("video", "image")]
        images = (f"; the dataset's observations are {', '.join(visual)} (images), and task {task.name!r} is "
                  "low-dimensional") if visual and what == "state" else ""
        raise ScdpError(name, f"no such feature (the {what}; the dataset has {', '.join(sorted(features))}){images}")
    shape = features[name]["shape"]
    if dim is not None and shape != [dim]:
        raise ScdpError(name, f"expected shape [{dim}] (task {task.name!r}'s {what}), got {shape}{hint}")


def _mapping(info: dict, task: Task, state: str, action: str, goals: str | None, target: str | None,
             action_from: str) -> dict:
    """Which feature holds what (the module docstring's defaults), each checked against the task; one feature
    named for two things is refused."""
    if action_from not in ACTION_FROM:
        raise ScdpError("--action-from", f"one of {', '.join(ACTION_FROM)}, got {action_from!r}")
    features = info["features"]
    if goals is None:
        goals = next((g for g in (ENV_STATE, GOALS) if g in features), None)
    if target is None and goals is not None:
        target = {ENV_STATE: TARGET_SLOT, GOALS: TARGET}.get(goals)
        target = target if target in features else None
    mapping = {"state": state, "action": action if action_from == "feature" else None, "goals": goals, "target": target}
    named = [(what, name) for what, name in mapping.items() if name is not None]
    for i, (what, name) in enumerate(named):
        other = next((w for w, n in named[:i] if n == name), None)
        if other is not None or name in ("timestamp", "frame_index", "episode_index"):
            raise ScdpError(f"--{what}-feature", f"{name} is already {f'the {other}' if other else 'an index column'}: "
                                                 "each feature can hold one thing")
    _feature(info, state, task.state_dim, task, "state")
    if mapping["action"] is not None:
        _feature(info, action, task.state_dim, task, "action", NEXT_STATE_HINT)
    for what in ("goals", "target"):
        if mapping[what] is not None:
            _feature(info, mapping[what], None, task, what)
    return mapping


def _column(table: pa.Table, name: str) -> np.ndarray:
    """One column as (N,) or, for a list column, (N, d): refused when its rows have different lengths."""
    column = table.column(name).combine_chunks()
    if pa.types.is_list(column.type) or pa.types.is_large_list(column.type) or pa.types.is_fixed_size_list(column.type):
        lengths = np.asarray(pc.list_value_length(column).fill_null(-1).to_numpy(zero_copy_only=False))
        if len(set(lengths.tolist())) > 1 or (len(lengths) and lengths[0] < 0):
            row = int(np.argmax(lengths != lengths[0])) if len(set(lengths.tolist())) > 1 else 0
            raise ScdpError(name, f"rows of different lengths (row 0 has {lengths[0]} values, row {row} "
                                  f"{lengths[row]}): a feature has one shape")
        flat = column.flatten().to_numpy(zero_copy_only=False)
        return np.asarray(flat, dtype=np.float64).reshape(len(table), -1)
    return np.asarray(column.to_numpy(zero_copy_only=False))


def _index(values: np.ndarray, name: str) -> np.ndarray:
    """An index column as int64: finite whole numbers, not below 0."""
    values = np.asarray(values).reshape(-1)
    if values.dtype.kind not in "iuf" or not np.all(np.isfinite(values)) or np.any(values != np.round(values)):
        bad = next((v for v in values.tolist() if not isinstance(v, (int, float)) or not np.isfinite(v) or v != round(v)),
                   values.dtype)
        raise ScdpError(name, f"must hold whole numbers, found {bad!r}")
    if values.size and values.min() < 0:
        raise ScdpError(name, f"must not be negative, found {int(values.min())}")
    return values.astype(np.int64)


def _read_frames(root: Path, wanted: list[str]) -> dict[str, np.ndarray]:
    """The ``wanted`` columns of every data file, in order of episode, then frame."""
    files = sorted((root / "data").glob("**/*.parquet"))
    if not files:
        raise ScdpError("data", f"{root} has no data/**/*.parquet files")
    try:
        table = pa.concat_tables([pq.read_table(f, columns=wanted) for f in files])
    except (pa.ArrowInvalid, pa.ArrowTypeError, KeyError, OSError) as exc:
        raise ScdpError("data", f"cannot read the columns {', '.join(wanted)} ({str(exc).splitlines()[0]})") from None
    if len(table) == 0:
        raise ScdpError("data", f"{root}'s data files hold no frames")
    cols = {name: _column(table, name) for name in wanted}
    for name in ("episode_index", "frame_index", "task_index"):
        if name in cols:
            cols[name] = _index(cols[name], name)
    order = np.lexsort((cols["frame_index"], cols["episode_index"]))
    return {k: v[order] for k, v in cols.items()}


def _task_texts(root: Path) -> list[str] | None:
    """``meta/tasks.parquet``'s texts in task_index order: LeRobot's pandas index (or a ``task`` column); None
    where the file is missing or unreadable (the texts are kept for the export, not needed for the demos)."""
    try:
        table = pq.read_table(root / TASKS_FILE)
    except (OSError, pa.ArrowInvalid):
        return None
    meta = json.loads((table.schema.metadata or {}).get(b"pandas", b"{}"))
    index = [c for c in meta.get("index_columns", []) if isinstance(c, str)]
    text = "task" if "task" in table.column_names else (index[0] if index else None)
    if text is None or "task_index" not in table.column_names:
        return None
    pairs = sorted(zip(table.column("task_index").to_pylist(), table.column(text).to_pylist()))
    return [str(t) for _, t in pairs]


def _goals(task: Task, first: np.ndarray, slot, goal_dim: int, mapping: dict, field: str) -> tuple[np.ndarray, int]:
    """One episode's goals (K, G) and target from its first frame's goals feature and target (``slot``)."""
    if first.size % goal_dim:
        raise ScdpError(mapping["goals"], f"{first.size} values do not split into goals of {goal_dim} coordinates")
    g = task.validate_goals(first.reshape(-1, goal_dim), 0, field=f"{field}: {mapping['goals']}")
    t = 0
    if slot is not None:
        value = float(np.asarray(slot, dtype=np.float64).reshape(-1)[0])
        if not np.isfinite(value) or value != round(value) or not 0 <= value < len(g):
            raise ScdpError(mapping["target"], f"{field}: {value:g} is not the index of one of its {len(g)} goals")
        t = int(value)
    if mapping["goals"] == ENV_STATE and mapping["target"] == TARGET_SLOT:  # g* first: back to where it stood
        g = np.insert(g[1:], t, g[0], axis=0)
    return g, t


def import_lerobot(path, task: Task | str, *, state: str = STATE, action: str = ACTION, goals: str | None = None,
                   target: str | None = None, goal_dim: int | None = None, action_from: str = "feature") -> DemoDataset:
    """A LeRobot v3 dataset's episodes as scdp demos (module docstring: the mapping)."""
    task = get_task(task)
    root = Path(path)
    info = read_info(root)
    fps = float(info["fps"])
    mapping = _mapping(info, task, state, action, goals, target, action_from)
    wanted = list(dict.fromkeys(c for c in (*mapping.values(), "timestamp", "frame_index", "episode_index")
                                if c is not None))
    if "task_index" in info["features"]:
        wanted.append("task_index")
    cols = _read_frames(root, wanted)
    episode, frame = cols["episode_index"], cols["frame_index"]
    timestamp = cols["timestamp"].astype(np.float64).reshape(-1)
    off = np.abs(timestamp - frame / fps)
    if not np.all(off <= TIME_TOLERANCE):
        i = int(np.argmax(~(off <= TIME_TOLERANCE)))
        raise ScdpError("timestamp", f"must be relative to its episode (frame_index / fps): episode {episode[i]} frame "
                                     f"{frame[i]} has {timestamp[i]:.4f} s, expected {frame[i] / fps:.4f} s (absolute "
                                     "times are offset twice by every reader)")
    goal_dim = task.space_dim if goal_dim is None else goal_dim
    texts = _task_texts(root)
    episodes, tasks = [], []
    for e in np.unique(episode):
        rows = np.flatnonzero(episode == e)
        if not np.array_equal(frame[rows], np.arange(len(rows))):
            raise ScdpError("frame_index", f"episode {e} does not hold frames 0..{len(rows) - 1} once each")
        field = f"episode {e}"
        if len(rows) < MIN_STEPS:
            raise ScdpError(field, f"has {len(rows)} frames; a demo needs at least {MIN_STEPS}")
        states = task.check_states(cols[state][rows], f"{field}: {state}", what="frame")
        if mapping["action"] is None:  # each action the next frame's state; the last frame holds still
            actions = np.vstack([states[1:], states[-1:]])
        else:
            actions = task.check_states(cols[action][rows], f"{field}: {action}", what="frame")
        if mapping["goals"] is not None:
            slot = cols[mapping["target"]][rows[0]] if mapping["target"] is not None else None
            g, t = _goals(task, np.asarray(cols[mapping["goals"]][rows[0]], dtype=np.float64).reshape(-1), slot,
                          goal_dim, mapping, field)
        else:  # from the task: g* where the episode ends, one distractor from the task's sampler
            rng = stream_rng(DEMOS, int(e), "lerobot")
            g, t = task.validate_goals(np.stack([task.task_space(states[-1]), task.sample_goals(rng, 2)[1]]), 0,
                                       field=f"{field}: goals from the task"), 0
        episodes.append({"state": states, "action": actions, "goals": g, "target": t})
        i = int(cols["task_index"][rows[0]]) if "task_index" in cols else -1
        tasks.append(texts[i] if texts is not None and 0 <= i < len(texts) else None)
    features = info["features"]
    kept = {"fps": int(fps) if fps.is_integer() else fps, "robot_type": info.get("robot_type"),
            "names": {key: features[name].get("names") for key, name in
                      ((STATE, state), (ACTION, mapping["action"]), (ENV_STATE, mapping["goals"]))
                      if name is not None and isinstance(features[name].get("names"), list)},
            **({"tasks": tasks} if all(t is not None for t in tasks) else {})}
    attrs = {"source": f"lerobot:{root.name}", "codebase_version": info["codebase_version"],
             "info_sha256": file_sha256(root / "meta" / "info.json"), "lerobot": kept,
             "mapping": {**mapping, "goals": mapping["goals"] or "task", "action_from": action_from},
             "mapping_digest": digest([state, mapping["action"], mapping["goals"], mapping["target"], goal_dim,
                                       action_from])}
    return DemoDataset.from_episodes(task.name, episodes, attrs)
