"""Broken LeRobot datasets: each is refused in one line that names its real cause, with no traceback and nothing
written (issue 77). Every case starts from a good v3 dataset written by hand (test_lerobot.documented_v3) and
breaks one thing."""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from test_lerobot import documented_v3

from scdp.cli import main

DATA = ("data", "chunk-000", "file-000.parquet")


def edit_info(root, change):
    path = root / "meta" / "info.json"
    info = json.loads(path.read_text())
    path.write_text(json.dumps(change(info)))


def edit_data(root, change):
    path = root.joinpath(*DATA)
    pq.write_table(change(pq.read_table(path)), path)


def set_column(name, values):
    def change(table):
        return table.set_column(table.column_names.index(name), name, pa.array(values))
    return change


def _info(**updates):
    return lambda root: edit_info(root, lambda info: {**info, **updates})


def _feature(name, spec):
    return lambda root: edit_info(root, lambda info: {**info, "features": {**info["features"], name: spec}})


def _column(name, make):
    return lambda root: edit_data(root, lambda t: set_column(name, make(t))(t))


def _ragged(table):
    rows = table.column("observation.state").to_pylist()
    rows[3] = rows[3][:2]
    return rows


CASES = {  # name: (break it, extra import arguments, the one line's start (field: problem) and a phrase in it)
    "info_not_json": (lambda r: (r / "meta" / "info.json").write_text("{fps: 10"), [], "meta/info.json: not JSON"),
    "info_a_list": (lambda r: (r / "meta" / "info.json").write_text("[1, 2]"), [],
                    "meta/info.json: must be a JSON object, got a list"),
    "no_info": (lambda r: (r / "meta" / "info.json").unlink(), [], "lerobot: "),
    "version_2": (_info(codebase_version="v2.1"), [], "meta/info.json: codebase_version v2.1"),
    "features_a_list": (_info(features=["observation.state"]), [], "meta/info.json: features: must be an object"),
    "feature_spec_a_list": (_feature("observation.state", [3]), [],
                            "meta/info.json: features: observation.state: must be an object with a 'shape' list"),
    "fps_missing": (lambda r: edit_info(r, lambda i: {k: v for k, v in i.items() if k != "fps"}), [],
                    "meta/info.json: fps: missing"),
    "fps_zero": (_info(fps=0), [], "meta/info.json: fps: must be above 0"),
    "fps_negative": (_info(fps=-10), [], "meta/info.json: fps: must be above 0"),
    "fps_true": (_info(fps=True), [], "meta/info.json: fps: must be a number of frames per second, got true"),
    "fps_nan": (lambda r: (r / "meta" / "info.json").write_text(
        (r / "meta" / "info.json").read_text().replace('"fps": 10', '"fps": NaN')), [],
        "meta/info.json: fps: must be a number of frames per second, got NaN"),
    "fps_text": (_info(fps="10"), [], "meta/info.json: fps: must be a number of frames per second, got \"10\""),
    "state_missing": (lambda r: edit_info(r, lambda i: {**i, "features": {
        k: v for k, v in i["features"].items() if k != "observation.state"}}), [], "observation.state: no such feature"),
    "action_cmd_vel": (_feature("action", {"dtype": "float32", "shape": [2], "names": None}), [],
                       "action: expected shape [3] (task 'navigation''s action), got [2]; a recording of velocity"),
    "no_data_files": (lambda r: r.joinpath(*DATA).unlink(), [], "data: "),
    "data_not_parquet": (lambda r: r.joinpath(*DATA).write_bytes(b"not parquet"), [], "data: cannot read the columns"),
    "data_missing_timestamp": (lambda r: edit_data(r, lambda t: t.drop_columns(["timestamp"])), [],
                               "data: cannot read the columns"),
    "data_empty": (lambda r: edit_data(r, lambda t: t.slice(0, 0)), [], "data: "),
    "ragged_state": (_column("observation.state", _ragged), [], "observation.state: rows of different lengths"),
    "nan_target_index": (lambda r: (_feature("target_index", {"dtype": "float32", "shape": [1], "names": None})(r),
                                    edit_data(r, lambda t: t.append_column("target_index", pa.array(
                                        np.full(len(t), np.nan, dtype=np.float32))))),
                         ["--target-feature", "target_index"], "target_index: episode 0: nan is not the index"),
    "negative_episode_index": (_column("episode_index", lambda t: np.r_[-1, t.column("episode_index").to_numpy()[1:]]),
                               [], "episode_index: must not be negative, found -1"),
    "fractional_frame_index": (_column("frame_index", lambda t: t.column("frame_index").to_numpy() + 0.5), [],
                               "frame_index: must hold whole numbers, found 0.5"),
    "nan_state": (_column("observation.state", lambda t: [[np.nan, 0.0, 0.0]] + t.column("observation.state").to_pylist()[1:]),
                  [], "episode 0: observation.state: frame 0 contains NaN or inf"),
    "action_is_the_state": (lambda r: None, ["--action-feature", "observation.state"],
                            "--action-feature: observation.state is already the state"),
    "goals_are_the_action": (lambda r: None, ["--goals-feature", "action"], "--goals-feature: action is already the action"),
    "target_is_frame_index": (lambda r: None, ["--target-feature", "frame_index"],
                              "--target-feature: frame_index is already an index column"),
    "target_is_the_goals": (lambda r: None, ["--target-feature", "observation.environment_state"],
                            "--target-feature: observation.environment_state is already the goals"),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_broken_dataset_is_refused_in_one_line_naming_its_cause(name, small_datasets, tmp_path, capsys):
    root = documented_v3(tmp_path / "d", small_datasets["navigation"])
    breaks, extra, words = CASES[name]
    breaks(root)
    code = main(["import-lerobot", str(root), "--task", "navigation", *extra, "--out", str(tmp_path / "x.zarr")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("scdp: error: " + words.split(": ")[0] + ":") and words in err, err
    assert "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "x.zarr").exists()


def test_the_table_holds_at_least_twenty_broken_datasets():
    assert len(CASES) >= 20
