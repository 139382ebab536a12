"""How LeRobot (v3, lerobot 0.4.x) reads a dataset folder, re-told with pyarrow for the tests: what its reader,
tools and policies take from each file. Written from LeRobot's format, not from scdp's writer, so a test that
reads an export through it checks the export against LeRobot, not against itself. docs/data.md shows how to
check an export with the real lerobot (Python 3.12, its own venv)."""

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

STATS = ("min", "max", "mean", "std", "count", "q01", "q10", "q50", "q90", "q99")
# DatasetInfo's fields: a key beyond them is logged as "Unknown fields in DatasetInfo" and dropped
INFO_FIELDS = {"codebase_version", "robot_type", "total_episodes", "total_frames", "total_tasks", "chunks_size",
               "data_files_size_in_mb", "video_files_size_in_mb", "fps", "splits", "data_path", "video_path",
               "features", "tools"}


def task_index_texts(root: Path) -> list:
    """What ``pandas.read_parquet(meta/tasks.parquet)`` gives as the frame's index, row by row: LeRobot's task
    texts (``tasks.iloc[i].name``). Without pandas metadata naming an index column, pandas numbers the rows."""
    table = pq.read_table(Path(root) / "meta" / "tasks.parquet")
    meta = json.loads((table.schema.metadata or {}).get(b"pandas", b"{}"))
    index = [c for c in meta.get("index_columns", []) if isinstance(c, str)]
    return table.column(index[0]).to_pylist() if index else list(range(len(table)))


def item_task(root: Path, frame: int):
    """``LeRobotDataset(root)[frame]["task"]``: the text at the frame's task_index, by position."""
    data = pq.read_table(Path(root) / "data" / "chunk-000" / "file-000.parquet", columns=["task_index"])
    return task_index_texts(root)[data.column("task_index")[frame].as_py()]


def feature_types(info: dict) -> dict:
    """How LeRobot's policies class each feature: VISUAL, ENV (exactly observation.environment_state), STATE
    (any other observation), ACTION; anything else is no input."""
    out = {}
    for key, spec in info["features"].items():
        if spec["dtype"] in ("image", "video"):
            out[key] = "VISUAL"
        elif key == "observation.environment_state":
            out[key] = "ENV"
        elif key.startswith("observation"):
            out[key] = "STATE"
        elif key.startswith("action"):
            out[key] = "ACTION"
    return out


def diffusion_accepts(info: dict) -> bool:
    """LeRobot's diffusion policy needs observation.state and at least one image or the environment state."""
    kinds = feature_types(info)
    return kinds.get("observation.state") == "STATE" and bool({"VISUAL", "ENV"} & set(kinds.values()))


def episode_stats(root: Path) -> list[dict]:
    """Each episode's statistics as LeRobot's tools read them from meta/episodes (``stats/<feature>/<stat>``)."""
    table = pq.read_table(Path(root) / "meta" / "episodes" / "chunk-000" / "file-000.parquet")
    rows = table.to_pylist()
    out = []
    for row in rows:
        stats: dict = {}
        for column, value in row.items():
            if column.startswith("stats/"):
                _, feature, stat = column.split("/")
                stats.setdefault(feature, {})[stat] = np.asarray(value, dtype=np.float64)
        out.append(stats)
    return out


def aggregate(episodes: list[dict]) -> dict:
    """LeRobot's pooling of per-episode statistics (what ``delete_episodes`` writes to stats.json): elementwise
    min and max, count-weighted mean and quantiles, the parallel-variance std, summed counts."""
    out = {}
    for feature in episodes[0] if episodes else {}:
        per = [e[feature] for e in episodes]
        c = np.array([p["count"][0] for p in per])
        mean = sum(ci * p["mean"] for ci, p in zip(c, per)) / c.sum()
        var = sum(ci * (p["std"] ** 2 + (p["mean"] - mean) ** 2) for ci, p in zip(c, per)) / c.sum()
        agg = {"min": np.min([p["min"] for p in per], axis=0), "max": np.max([p["max"] for p in per], axis=0),
               "mean": mean, "std": np.sqrt(var), "count": np.array([c.sum()])}
        agg.update({q: sum(ci * p[q] for ci, p in zip(c, per)) / c.sum() for q in STATS[5:] if q in per[0]})
        out[feature] = agg
    return out


def quantile_normalise(values: np.ndarray, stats: dict) -> np.ndarray:
    """LeRobot's QUANTILES normalisation: needs q01 and q99 (else ValueError), maps them to -1 and 1."""
    if "q01" not in stats or "q99" not in stats:
        raise ValueError("QUANTILES normalization mode requires q01 and q99 stats")
    q01, q99 = np.asarray(stats["q01"]), np.asarray(stats["q99"])
    return 2 * (values - q01) / np.where(q99 - q01 == 0, 1e-8, q99 - q01) - 1


def appendable(root: Path, features: list[str]) -> list[str]:
    """What ``LeRobotDataset.resume`` + ``add_frame``/``save_episode`` would write to meta/episodes that the
    existing file lacks (an appended file with more columns than the first makes the dataset fail to reopen)."""
    table = pq.read_table(Path(root) / "meta" / "episodes" / "chunk-000" / "file-000.parquet")
    lerobot = ["episode_index", "tasks", "length", "data/chunk_index", "data/file_index", "dataset_from_index",
               "dataset_to_index", *(f"stats/{f}/{s}" for f in features for s in STATS),
               "meta/episodes/chunk_index", "meta/episodes/file_index"]
    return [c for c in lerobot if c not in table.column_names]
