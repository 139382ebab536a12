import h5py
import numpy as np
import pytest

from scdp.data.dataset import DemoDataset
from scdp.data.robomimic import import_robomimic
from scdp.errors import ScdpError


def test_zarr_round_trip(small_datasets, tmp_path):
    ds = small_datasets["block_reach"]
    path = ds.save(tmp_path / "d.zarr")
    back = DemoDataset.load(path)
    assert back.task == "block_reach"
    for key in ("state", "action", "goal", "goals", "episode_ends", "target_index"):
        assert np.array_equal(getattr(back, key), getattr(ds, key)), key
    assert back.attrs["generator"]["seed"] == 3
    assert np.array(back.attrs["control_points"]).shape == (12, 3)
    # the layout is the documented one
    import zarr

    root = zarr.open_group(str(path), mode="r")
    assert root["data/goals"].shape == (ds.num_steps, 2, 3)
    assert root["meta/episode_ends"][-1] == ds.num_steps


def test_goal_column_is_the_target(small_datasets):
    ds = small_datasets["navigation"]
    for i in range(ds.num_episodes):
        a, b = ds.episode_bounds(i)
        assert np.allclose(ds.goal[a:b], ds.goals[a:b, ds.target_index[i]])


def test_save_refuses_to_overwrite_and_keeps_old(small_datasets, tmp_path):
    ds = small_datasets["navigation"]
    path = ds.save(tmp_path / "d.zarr")
    with pytest.raises(ScdpError, match="already exists"):
        ds.subset([0]).save(path)
    assert DemoDataset.load(path).num_episodes == ds.num_episodes
    ds.subset([0, 1]).save(path, force=True)
    assert DemoDataset.load(path).num_episodes == 2
    assert [p.name for p in tmp_path.iterdir()] == ["d.zarr"]  # no temporaries left


def test_load_refuses_missing_and_corrupt(tmp_path):
    with pytest.raises(ScdpError, match="does not exist"):
        DemoDataset.load(tmp_path / "nope.zarr")
    bad = tmp_path / "bad.zarr"
    bad.mkdir()
    (bad / "zarr.json").write_text("{not json")
    with pytest.raises(ScdpError) as err:
        DemoDataset.load(bad)
    assert err.value.field == "dataset"


def _write_h5(path, episodes, goal_dim):
    with h5py.File(path, "w") as f:
        for k, ep in enumerate(episodes):
            g = f.create_group(f"data/demo_{k}")
            g["states"] = ep["state"]
            g["actions"] = ep["action"]
            flat = np.asarray(ep["goals"])[:, :goal_dim].reshape(-1)
            g["obs/object"] = np.repeat(flat[None], len(ep["state"]), axis=0)


def test_hdf5_import_matches_source(small_datasets, tmp_path):
    ds = small_datasets["block_reach"]
    episodes = []
    for i in range(3):  # the authors' format puts g* first
        ep = ds.episode(i)
        order = [ep["target"]] + [k for k in range(len(ep["goals"])) if k != ep["target"]]
        episodes.append({**ep, "goals": ep["goals"][order]})
    _write_h5(tmp_path / "demos.hdf5", episodes, goal_dim=3)
    imported = import_robomimic(tmp_path / "demos.hdf5", "block_reach")
    assert imported.num_episodes == 3
    for i, ep in enumerate(episodes):
        got = imported.episode(i)
        assert np.allclose(got["state"], ep["state"], atol=1e-6)
        assert np.allclose(got["action"], ep["action"], atol=1e-6)
        assert got["target"] == 0
        assert np.allclose(got["goals"], ep["goals"], atol=1e-6)


def test_hdf5_import_accepts_xy_block_goals(small_datasets, tmp_path):
    ep = small_datasets["block_reach"].episode(0)
    _write_h5(tmp_path / "xy.hdf5", [ep], goal_dim=2)
    imported = import_robomimic(tmp_path / "xy.hdf5", "block_reach", goal_dim=2)
    assert np.allclose(imported.goals[0][:, 2], 0.1)


def test_hdf5_import_errors(small_datasets, tmp_path):
    ep = small_datasets["navigation"].episode(0)
    with h5py.File(tmp_path / "missing.hdf5", "w") as f:
        f["data/demo_0/states"] = ep["state"]
    with pytest.raises(ScdpError, match="actions"):
        import_robomimic(tmp_path / "missing.hdf5", "navigation")
    (tmp_path / "junk.hdf5").write_text("not hdf5")
    with pytest.raises(ScdpError, match="not a readable HDF5"):
        import_robomimic(tmp_path / "junk.hdf5", "navigation")
    _write_h5(tmp_path / "wrongtask.hdf5", [ep], goal_dim=2)
    with pytest.raises(ScdpError, match="states"):
        import_robomimic(tmp_path / "wrongtask.hdf5", "block_reach", goal_dim=2)


def _damaged(ds, **changes):
    from dataclasses import fields

    values = {f.name: getattr(ds, f.name) for f in fields(ds)}
    values = {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in values.items()}
    for key, fn in changes.items():
        values[key] = fn(values[key])
    return DemoDataset(**values)


def _set(index, value):
    def change(a):
        a[index] = value
        return a
    return change


@pytest.mark.parametrize("changes, field", [
    ({"state": _set((3, 0), np.nan)}, "data/state"),
    ({"action": _set((5, 1), np.inf)}, "data/action"),
    ({"goals": _set((0, 0, 0), -np.inf)}, "data/goals"),
    ({"state": lambda a: np.concatenate([a, a[:, :1]], axis=1), "action": lambda a: np.concatenate([a, a[:, :1]], axis=1)}, "task"),
    ({"target_index": _set(0, 2)}, "meta/target_index"),
    ({"target_index": _set(0, -1)}, "meta/target_index"),
    ({"goals": lambda a: a[:, :1]}, "data/goals"),
    ({"action": lambda a: a[:, :2]}, "data/action"),
    ({"task": lambda t: "block_reach"}, "task"),
    ({"episode_ends": lambda e: e.astype(np.float64) + 0.5}, "meta/episode_ends"),
])
def test_damaged_datasets_are_refused_by_name(small_datasets, changes, field):
    with pytest.raises(ScdpError) as err:
        _damaged(small_datasets["navigation"], **changes)
    assert err.value.field == field


def test_an_empty_dataset_is_refused(small_datasets):
    ds = small_datasets["navigation"]
    with pytest.raises(ScdpError, match="no episodes"):
        _damaged(ds, **{k: (lambda a: a[:0]) for k in ("state", "action", "goal", "goals", "episode_ends", "target_index")})


def test_hdf5_import_carries_n_goals_and_refuses_a_mixed_count(tmp_path):
    from scdp.data.generate import generate_demos

    ds, _ = generate_demos("navigation", 2, seed=4, n_goals=4, progress=False)
    episodes = []
    for i in range(2):
        ep = ds.episode(i)
        order = [ep["target"]] + [k for k in range(4) if k != ep["target"]]
        episodes.append({**ep, "goals": ep["goals"][order]})
    _write_h5(tmp_path / "four.hdf5", episodes, goal_dim=2)
    imported = import_robomimic(tmp_path / "four.hdf5", "navigation")
    assert imported.goals.shape[1:] == (4, 2) and np.allclose(imported.episode(1)["goals"], episodes[1]["goals"], atol=1e-6)
    episodes[1] = {**episodes[1], "goals": episodes[1]["goals"][:3]}
    _write_h5(tmp_path / "mixed.hdf5", episodes, goal_dim=2)
    with pytest.raises(ScdpError) as err:
        import_robomimic(tmp_path / "mixed.hdf5", "navigation")
    assert err.value.field == "data/demo_1/obs/object" and "one goal count" in err.value.message
