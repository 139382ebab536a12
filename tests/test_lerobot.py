"""LeRobot v3 datasets in and out, checked against the format, not only against scdp's own writer: a
fixture written by hand from the v3 documentation's field list, a reader that follows
lerobot-doctor's layout (meta/episodes/**, data/** grouped by episode_index, meta/tasks.parquet), and
the writer's known pitfalls (episode-relative timestamps)."""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from helpers.tiny import TINY
from scdp.cli import main
from scdp.data.dataset import DemoDataset
from scdp.tasks import NAVIGATION
from scdp.training import parts

FPS = 10.0


def documented_v3(root, demos: DemoDataset, *, absolute_time: bool = False, version: str = "v3.0", goals=True):
    """A v3 dataset written field by field as the v3 documentation lists them (meta/info.json with
    codebase_version, fps, features, data_path; data/chunk-000/file-000.parquet with the features and
    timestamp, frame_index, episode_index, index, task_index; meta/episodes and meta/tasks), by hand:
    not by scdp's writer. Goals go in ``observation.environment_state`` (g* first)."""
    ends = np.asarray(demos.episode_ends)
    starts = np.concatenate([[0], ends[:-1]])
    episode = np.repeat(np.arange(len(ends)), ends - starts)
    frame = np.arange(len(episode)) - starts[episode]
    time = (np.arange(len(episode)) if absolute_time else frame) / FPS
    env = demos.goals.reshape(len(episode), -1)
    columns = {"observation.state": pa.array(list(demos.state), type=pa.list_(pa.float32())),
               "action": pa.array(list(demos.action), type=pa.list_(pa.float32())),
               "timestamp": pa.array(time.astype(np.float32)), "frame_index": pa.array(frame.astype(np.int64)),
               "episode_index": pa.array(episode.astype(np.int64)), "index": pa.array(np.arange(len(episode), dtype=np.int64)),
               "task_index": pa.array(np.zeros(len(episode), dtype=np.int64))}
    features = {"observation.state": {"dtype": "float32", "shape": [3], "names": ["x", "y", "theta"]},
                "action": {"dtype": "float32", "shape": [3], "names": ["x", "y", "theta"]},
                **{k: {"dtype": "float32" if k == "timestamp" else "int64", "shape": [1], "names": None}
                   for k in ("timestamp", "frame_index", "episode_index", "index", "task_index")}}
    if goals:
        columns["observation.environment_state"] = pa.array(list(env), type=pa.list_(pa.float32()))
        features["observation.environment_state"] = {"dtype": "float32", "shape": [env.shape[1]], "names": None}
    (root / "data" / "chunk-000").mkdir(parents=True)
    (root / "meta" / "episodes" / "chunk-000").mkdir(parents=True)
    pq.write_table(pa.table(columns), root / "data" / "chunk-000" / "file-000.parquet")
    pq.write_table(pa.table({"episode_index": np.arange(len(ends)), "length": ends - starts,
                             "data/chunk_index": np.zeros(len(ends), dtype=np.int64),
                             "data/file_index": np.zeros(len(ends), dtype=np.int64),
                             "dataset_from_index": starts, "dataset_to_index": ends}),
                   root / "meta" / "episodes" / "chunk-000" / "file-000.parquet")
    pq.write_table(pa.table({"task_index": [0], "task": ["drive to the goal"]}), root / "meta" / "tasks.parquet")
    info = {"codebase_version": version, "robot_type": "turtlebot3", "total_episodes": len(ends),
            "total_frames": len(episode), "total_tasks": 1, "chunks_size": 1000, "fps": FPS,
            "splits": {"train": f"0:{len(ends)}"},
            "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
            "video_path": "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4", "features": features}
    (root / "meta" / "info.json").write_text(json.dumps(info))
    return root


def doctor_read(root) -> dict:
    """Read a v3 dataset as lerobot-doctor does, with pyarrow only: episodes from meta/episodes/**,
    frames from data/** grouped by episode_index, tasks from meta/tasks.parquet. Returns what it checks."""
    info = json.loads((root / "meta" / "info.json").read_text())
    episodes = pa.concat_tables([pq.read_table(p) for p in sorted((root / "meta" / "episodes").glob("**/*.parquet"))])
    data = pa.concat_tables([pq.read_table(p) for p in sorted((root / "data").glob("**/*.parquet"))])
    tasks = pq.read_table(root / "meta" / "tasks.parquet")
    frames = data.column("episode_index").to_numpy()
    lengths = dict(zip(*np.unique(frames, return_counts=True)))
    ep = episodes.to_pydict()
    return {"info": info, "lengths_agree": all(lengths[e] == n for e, n in zip(ep["episode_index"], ep["length"])),
            "ranges_agree": all(np.all(frames[a:b] == e) for e, a, b in
                                zip(ep["episode_index"], ep["dataset_from_index"], ep["dataset_to_index"])),
            "tasks_known": set(data.column("task_index").to_numpy()) <= set(tasks.column("task_index").to_pylist()),
            "totals": (info["total_episodes"], info["total_frames"]) == (len(ep["episode_index"]), len(frames)),
            "relative_time": bool(np.allclose(data.column("timestamp").to_numpy(),
                                              data.column("frame_index").to_numpy() / info["fps"], atol=1e-5))}


def test_a_documented_v3_dataset_imports_and_trains_the_tiny_base(small_datasets, tmp_path, capsys):
    demos = small_datasets["navigation"]
    root = documented_v3(tmp_path / "doc", demos)
    assert main(["import-lerobot", str(root), "--task", "navigation", "--goals-feature", "observation.environment_state",
                 "--out", str(tmp_path / "in.zarr")]) == 0
    imported = DemoDataset.load(tmp_path / "in.zarr")
    assert imported.num_episodes == demos.num_episodes and np.array_equal(imported.state, demos.state)
    assert np.array_equal(imported.goals, demos.goals) and imported.attrs["codebase_version"] == "v3.0"
    assert len(imported.attrs["info_sha256"]) == 64
    _, result = parts.train_diffusion(NAVIGATION, imported, TINY, tmp_path / "base", progress=False)
    assert (tmp_path / "base" / "model.safetensors").is_file() and result.steps > 0 and np.isfinite(result.losses).all()


def test_navigation_demos_round_trip_through_export_and_import(small_datasets, tmp_path):
    demos = small_datasets["navigation"]
    demos.save(tmp_path / "demos.zarr")
    assert main(["export-demos", str(tmp_path / "demos.zarr"), "--out", str(tmp_path / "lr")]) == 0
    assert main(["import-lerobot", str(tmp_path / "lr"), "--task", "navigation", "--out", str(tmp_path / "back.zarr")]) == 0
    back = DemoDataset.load(tmp_path / "back.zarr")
    for key in ("state", "action", "goal", "goals", "episode_ends", "target_index"):
        assert np.array_equal(getattr(back, key), getattr(demos, key)), key  # bit for bit (float32 both ways)
    assert main(["export-demos", str(tmp_path / "demos.zarr"), "--out", str(tmp_path / "lr")]) == 2  # no --force


def test_the_export_reads_as_lerobot_doctor_reads_it_with_episode_relative_timestamps(small_datasets, tmp_path):
    small_datasets["navigation"].save(tmp_path / "demos.zarr")
    assert main(["export-demos", str(tmp_path / "demos.zarr"), "--fps", "15", "--out", str(tmp_path / "lr")]) == 0
    found = doctor_read(tmp_path / "lr")
    assert found["info"]["codebase_version"] == "v3.0" and found["info"]["fps"] == 15.0
    assert found["lengths_agree"] and found["ranges_agree"] and found["tasks_known"] and found["totals"]
    assert found["relative_time"]  # frame_index / fps within each episode, never absolute
    stats = json.loads((tmp_path / "lr" / "meta" / "stats.json").read_text())
    assert set(stats["observation.state"]) == {"min", "max", "mean", "std", "count"}


def test_absolute_timestamps_are_refused_naming_the_pitfall(small_datasets, tmp_path, capsys):
    root = documented_v3(tmp_path / "abs", small_datasets["navigation"], absolute_time=True)
    assert main(["import-lerobot", str(root), "--task", "navigation", "--goals-feature", "observation.environment_state",
                 "--out", str(tmp_path / "x.zarr")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("scdp: error: timestamp: must be relative to its episode") and "\n" not in err
    assert not (tmp_path / "x.zarr").exists()


@pytest.mark.parametrize("change, words", [
    ("v2", "meta/info.json: codebase_version v2.1: scdp reads LeRobot v3 datasets"),
    ("no_state", "observation.state: no such feature (the state;"),
    ("wide_state", "observation.state: expected shape [3] (task 'navigation''s state), got [4]"),
    ("video_only", "the dataset's observations are observation.images.front (images), and task 'navigation' is low-dimensional"),
])
def test_what_cannot_be_mapped_is_refused_in_one_line(small_datasets, tmp_path, capsys, change, words):
    root = documented_v3(tmp_path / "d", small_datasets["navigation"], version="v2.1" if change == "v2" else "v3.0")
    info = json.loads((root / "meta" / "info.json").read_text())
    if change in ("no_state", "video_only"):
        info["features"].pop("observation.state")
    if change == "video_only":
        info["features"]["observation.images.front"] = {"dtype": "video", "shape": [96, 96, 3], "names": None}
    if change == "wide_state":
        info["features"]["observation.state"]["shape"] = [4]
    (root / "meta" / "info.json").write_text(json.dumps(info))
    assert main(["import-lerobot", str(root), "--task", "navigation", "--out", str(tmp_path / "x.zarr")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("scdp: error: ") and words in err and "\n" not in err


def test_without_a_goals_feature_the_goals_come_from_the_task(small_datasets, tmp_path):
    """g* is where each episode ends; one distractor from the task's sampler, the same on every import."""
    demos = small_datasets["navigation"]
    root = documented_v3(tmp_path / "d", demos, goals=False)
    for name in ("a.zarr", "b.zarr"):
        assert main(["import-lerobot", str(root), "--task", "navigation", "--out", str(tmp_path / name)]) == 0
    a, b = DemoDataset.load(tmp_path / "a.zarr"), DemoDataset.load(tmp_path / "b.zarr")
    assert np.array_equal(a.goals, b.goals) and a.attrs["mapping"]["goals"] == "task"
    last = np.asarray(demos.episode_ends) - 1
    assert np.allclose(a.goal[last], NAVIGATION.task_space(demos.state[last].astype(np.float64)), atol=1e-6)


def test_without_the_extra_the_command_names_it(tmp_path, capsys, monkeypatch):
    import sys

    import scdp.data

    monkeypatch.setitem(sys.modules, "pyarrow", None)  # as if pyarrow were not installed
    for name in ("scdp.data.lerobot", "scdp.cli.lerobot"):  # imported again, without it
        monkeypatch.delitem(sys.modules, name, raising=False)
    monkeypatch.delattr(scdp.data, "lerobot", raising=False)
    assert main(["export-demos", str(tmp_path / "d.zarr"), "--out", str(tmp_path / "lr")]) == 2
    assert capsys.readouterr().err.strip() == "scdp: error: export-demos: needs pyarrow: pip install 'scdp[lerobot]'"
