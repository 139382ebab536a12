"""LeRobot v3 datasets in and out, checked against the format, not only against scdp's own writer: a
fixture written by hand from the v3 documentation's field list, a reader that follows
lerobot-doctor's layout (meta/episodes/**, data/** grouped by episode_index, meta/tasks.parquet), and
the writer's known pitfalls (episode-relative timestamps)."""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from helpers import lerobot_reader as lr
from helpers.tiny import TINY
from scdp.cli import main
from scdp.data.dataset import DemoDataset
from scdp.tasks import NAVIGATION
from scdp.training import parts

FPS = 10  # LeRobot writes fps as an integer


def pandas_tasks(texts: list[str]) -> pa.Table:
    """meta/tasks.parquet as pandas writes LeRobot's: a task_index column, the texts as the frame's index."""
    meta = {"index_columns": ["__index_level_0__"], "column_indexes": [], "columns": [
        {"name": "task_index", "field_name": "task_index", "pandas_type": "int64", "numpy_type": "int64", "metadata": None},
        {"name": None, "field_name": "__index_level_0__", "pandas_type": "unicode", "numpy_type": "object", "metadata": None}]}
    schema = pa.schema([("task_index", pa.int64()), ("__index_level_0__", pa.string())],
                       metadata={b"pandas": json.dumps(meta).encode()})
    return pa.table({"task_index": list(range(len(texts))), "__index_level_0__": texts}, schema=schema)


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
    pq.write_table(pandas_tasks(["drive to the goal"]), root / "meta" / "tasks.parquet")
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
    assert found["info"]["codebase_version"] == "v3.0" and found["info"]["fps"] == 15
    assert found["lengths_agree"] and found["ranges_agree"] and found["tasks_known"] and found["totals"]
    assert found["relative_time"]  # frame_index / fps within each episode, never absolute


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
    for name in ("scdp.data.lerobot", "scdp.data.lerobot_export", "scdp.cli.lerobot"):  # imported again, without it
        monkeypatch.delitem(sys.modules, name, raising=False)
    monkeypatch.delattr(scdp.data, "lerobot", raising=False)
    monkeypatch.delattr(scdp.data, "lerobot_export", raising=False)
    assert main(["export-demos", str(tmp_path / "d.zarr"), "--out", str(tmp_path / "lr")]) == 2
    assert capsys.readouterr().err.strip() == "scdp: error: export-demos: needs pyarrow: pip install 'scdp[lerobot]'"


# -- what LeRobot's reader, tools and policies take from an export (issue 77) -------------------------------------
@pytest.fixture
def exported(small_datasets, tmp_path):
    small_datasets["navigation"].save(tmp_path / "demos.zarr")
    assert main(["export-demos", str(tmp_path / "demos.zarr"), "--out", str(tmp_path / "lr")]) == 0
    return tmp_path / "lr"


def test_lerobots_reader_reads_the_task_text_as_text(small_datasets, exported, tmp_path):
    assert lr.item_task(exported, 0) == "reach the target goal"  # not task_index 0, as a plain column gives
    small_datasets["navigation"].save(tmp_path / "d2.zarr")
    assert main(["export-demos", str(tmp_path / "d2.zarr"), "--task-text", "go to the red block", "--robot-type",
                 "turtlebot3_burger", "--out", str(tmp_path / "lr2")]) == 0
    assert lr.item_task(tmp_path / "lr2", 5) == "go to the red block"
    assert json.loads((tmp_path / "lr2" / "meta" / "info.json").read_text())["robot_type"] == "turtlebot3_burger"


def test_the_goals_sit_where_lerobots_policies_read_the_environment(small_datasets, exported):
    info = json.loads((exported / "meta" / "info.json").read_text())
    assert lr.feature_types(info)["observation.environment_state"] == "ENV" and lr.diffusion_accepts(info)
    assert "observation.goals" not in info["features"]  # a STATE to LeRobot: its diffusion policy refused the export
    demos = small_datasets["navigation"]
    env = pq.read_table(exported / "data" / "chunk-000" / "file-000.parquet").column("observation.environment_state")
    first = np.asarray(env[0].as_py(), dtype=np.float32)
    assert np.array_equal(first[:2], demos.goals[0, demos.target_index[0]].astype(np.float32))  # g* first


def test_lerobot_can_append_to_an_export_and_rebuild_its_stats_after_deleting_episodes(small_datasets, exported):
    info = json.loads((exported / "meta" / "info.json").read_text())
    assert lr.appendable(exported, list(info["features"])) == []  # LeRobot's appended rows carry no column it lacks
    episodes = lr.episode_stats(exported)
    assert len(episodes) == small_datasets["navigation"].num_episodes
    kept = lr.aggregate([e for i, e in enumerate(episodes) if i % 2])  # delete_episodes: stats from the rest
    state = small_datasets["navigation"].state.astype(np.float32).astype(np.float64)
    ends = np.asarray(small_datasets["navigation"].episode_ends)
    rows = np.concatenate([np.arange(a, b) for i, (a, b) in enumerate(zip(np.r_[0, ends[:-1]], ends)) if i % 2])
    assert np.allclose(kept["observation.state"]["mean"], state[rows].mean(0), atol=1e-6)
    assert np.array_equal(kept["observation.state"]["max"], state[rows].max(0))


def test_stats_json_carries_lerobots_quantiles_pooled_from_the_episodes(small_datasets, exported):
    stats = json.loads((exported / "meta" / "stats.json").read_text())
    state = small_datasets["navigation"].state.astype(np.float32).astype(np.float64)
    pooled = lr.aggregate(lr.episode_stats(exported))["observation.state"]
    for q in ("q01", "q10", "q50", "q90", "q99"):
        assert np.allclose(stats["observation.state"][q], pooled[q], atol=1e-9)  # stats.json = its episodes pooled
    low, high = state.min(0), state.max(0)
    assert np.all(low <= np.array(stats["observation.state"]["q01"])) and np.all(np.array(stats["observation.state"]["q99"]) <= high)
    normalised = lr.quantile_normalise(state, stats["observation.state"])  # QUANTILES mode accepts it
    assert np.isfinite(normalised).all() and np.median(np.abs(normalised)) < 1


def test_each_episodes_quantiles_are_lerobots_binned_ones_not_numpys():
    """LeRobot's q50 of 0..9 (10 values): 5000 bins over [0, 9], the bin holding the 5th value, interpolated to
    its start plus nothing (5 values at or below 4.5 fill it exactly)..."""
    from scdp.data.lerobot_stats import feature_stats

    values = np.arange(10, dtype=np.float64)[:, None]
    stats = feature_stats(values)
    width = (9 + 2e-10) / 5000
    assert np.isclose(stats["q50"][0], -1e-10 + np.ceil((4 + 1e-10) / width) * width, atol=1e-12)  # end of 4's bin
    assert not np.isclose(stats["q50"][0], np.quantile(values, 0.5))  # numpy says 4.5
    assert stats["count"].tolist() == [10] and stats["std"][0] == np.std(values)


def test_provenance_lives_in_a_file_of_its_own(exported):
    info = json.loads((exported / "meta" / "info.json").read_text())
    assert set(info) <= lr.INFO_FIELDS  # nothing LeRobot logs as unknown and drops
    assert json.loads((exported / "meta" / "scdp.json").read_text())["task"] == "navigation"


def test_a_lerobot_dataset_keeps_its_names_task_robot_and_fps_through_scdp(small_datasets, tmp_path):
    root = documented_v3(tmp_path / "doc", small_datasets["navigation"])
    info = json.loads((root / "meta" / "info.json").read_text())
    info["features"]["observation.state"]["names"] = ["px", "py", "yaw"]
    (root / "meta" / "info.json").write_text(json.dumps(info))
    assert main(["import-lerobot", str(root), "--task", "navigation", "--out", str(tmp_path / "in.zarr")]) == 0
    assert main(["export-demos", str(tmp_path / "in.zarr"), "--out", str(tmp_path / "back")]) == 0
    back = json.loads((tmp_path / "back" / "meta" / "info.json").read_text())
    assert back["features"]["observation.state"]["names"] == ["px", "py", "yaw"]
    assert back["features"]["action"]["names"] == ["x", "y", "theta"]
    assert back["robot_type"] == "turtlebot3" and back["fps"] == 10 and isinstance(back["fps"], int)
    assert lr.item_task(tmp_path / "back", 0) == "drive to the goal"


def test_scdps_goals_come_back_in_their_order_with_g_star_anywhere(small_datasets, tmp_path):
    demos = small_datasets["block_reach"]
    moved = DemoDataset.from_episodes(demos.task, [
        {**ep, "goals": ep["goals"][::-1], "target": len(ep["goals"]) - 1 - ep["target"]}
        for ep in (demos.episode(i) for i in range(demos.num_episodes))], demos.attrs)
    assert set(moved.target_index.tolist()) != {0}
    moved.save(tmp_path / "demos.zarr")
    assert main(["export-demos", str(tmp_path / "demos.zarr"), "--out", str(tmp_path / "lr")]) == 0
    assert main(["import-lerobot", str(tmp_path / "lr"), "--task", "block_reach", "--out", str(tmp_path / "b.zarr")]) == 0
    back = DemoDataset.load(tmp_path / "b.zarr")
    assert np.array_equal(back.goals, moved.goals) and np.array_equal(back.target_index, moved.target_index)


def test_a_state_only_recording_imports_with_actions_from_the_next_state(small_datasets, tmp_path):
    demos = small_datasets["navigation"]
    root = documented_v3(tmp_path / "d", demos)
    table = pq.read_table(root / "data" / "chunk-000" / "file-000.parquet").drop_columns(["action"])
    pq.write_table(table, root / "data" / "chunk-000" / "file-000.parquet")
    info = json.loads((root / "meta" / "info.json").read_text())
    info["features"].pop("action")
    (root / "meta" / "info.json").write_text(json.dumps(info))
    assert main(["import-lerobot", str(root), "--task", "navigation", "--action-from", "next-state",
                 "--out", str(tmp_path / "in.zarr")]) == 0
    back = DemoDataset.load(tmp_path / "in.zarr")
    ends = np.asarray(demos.episode_ends)
    inner = np.setdiff1d(np.arange(len(demos.state)), ends - 1)
    assert np.array_equal(back.action[inner], back.state[inner + 1])  # each action the next frame's state
    assert np.array_equal(back.action[ends - 1], back.state[ends - 1])  # the last frame holds still


def test_a_velocity_command_recording_is_refused_naming_the_option(small_datasets, tmp_path, capsys):
    root = documented_v3(tmp_path / "d", small_datasets["navigation"])
    info = json.loads((root / "meta" / "info.json").read_text())
    info["features"]["action"] = {"dtype": "float32", "shape": [2], "names": ["linear.x", "angular.z"]}
    (root / "meta" / "info.json").write_text(json.dumps(info))
    assert main(["import-lerobot", str(root), "--task", "navigation", "--out", str(tmp_path / "x.zarr")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("scdp: error: action: expected shape [3]") and "--action-from next-state" in err
    assert "\n" not in err and not (tmp_path / "x.zarr").exists()
