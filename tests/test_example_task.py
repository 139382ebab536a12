"""The example robot of examples/planar_arm (a task defined outside the library, found only through
``--task examples.planar_arm:TASK``) through every command: reproduce, report, plan, evaluate,
export, serve, study, import-hdf5 and train. Also: nothing in src/scdp names it."""

import importlib
import json
import shutil
from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest
from fastapi.testclient import TestClient

from scdp import tasks
from scdp.cli import main
from scdp.content import explain
from scdp.data.dataset import DemoDataset
from scdp.data.task_key import task_key
from scdp.pipeline.plan import pending, plan_stages
from scdp.presets import get_preset
from scdp.serve.app import PlanningService, create_app
from scdp.serve.batcher import BatchingOptions
from scdp.study.make import read_study

REPO = Path(__file__).resolve().parents[1]
SPEC = "examples.planar_arm:TASK"
GOALS = ["0.6,0.12", "0.6,-0.12"]


@pytest.fixture(scope="module")
def arm_run(tmp_path_factory):
    """`scdp reproduce --task examples.planar_arm:TASK --preset tiny`, run from the repository root."""
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(REPO)
        mp.setattr(tasks, "_LOADED", {})
        out = tmp_path_factory.mktemp("arm") / "run"
        assert main(["reproduce", "--task", SPEC, "--preset", "tiny", "--out", str(out)]) == 0
    return out


@pytest.fixture
def at_repo(monkeypatch):
    monkeypatch.chdir(REPO)
    monkeypatch.setattr(tasks, "_LOADED", {})  # each test finds the task again, as a new process would


def test_nothing_in_the_library_names_the_example():
    named = [p for p in (REPO / "src" / "scdp").rglob("*") if p.is_file() and p.suffix in (".py", ".html", ".toml")
             and ("planar_arm" in p.read_text() or "examples." in p.read_text())]
    assert not named


def test_the_example_reproduces_and_its_report_rebuilds_in_a_new_process(arm_run, at_repo, tmp_path):
    results = json.loads((arm_run / "results.json").read_text())
    assert results["task_references"] == {"planar_arm": SPEC}
    assert {r["task"] for r in results["trajectories"]} == {"planar_arm"}
    methods = {r["method"] for r in results["trajectories"]}
    assert {"dp", "ld", "scdp", "scdp_legible", "scdp_efficient"} <= methods
    for part in ("base", "ld", "encoder", "style_legible", "style_efficient"):
        assert (arm_run / "planar_arm" / "checkpoints" / part / "model.safetensors").is_file()
    report = (arm_run / "report.md").read_text()
    assert "*Planar arm*" in report and "planar_arm | ambiguous | scdp − dp" in report
    assert "navigation" not in report.lower() and "block_reach" not in report  # only its own task: no paper rows
    # `scdp report` in a process that never loaded the task finds it through results.json
    rebuilt = tmp_path / "again"
    shutil.copytree(arm_run / "planar_arm" / "demos.zarr", rebuilt / "planar_arm" / "demos.zarr")  # the report reads its j range
    assert main(["report", str(arm_run / "results.json"), "--out", str(rebuilt)]) == 0
    assert (rebuilt / "report.md").read_text().split("\n", 3)[3] == report.split("\n", 3)[3]


def test_the_example_s_lateral_cap_is_under_the_key(arm_run, at_repo):
    """Changing the example arm's own field (its demonstrations' lateral cap) makes every stage of its
    run stale, the demos and all after them, naming the task; the unchanged task makes none."""
    task, preset = tasks.get_task(SPEC), get_preset("tiny")
    folder = arm_run / "planar_arm"
    assert pending(plan_stages(task, preset, folder)) == []
    changed = pending(plan_stages(replace(task, lateral_cap=0.10), preset, folder))
    names = [s.name for s in plan_stages(task, preset, folder)]
    assert [name for name, _ in changed] == names and "demos" in names and names[-1] == "evaluate"
    assert all(c == ["task"] for _, c in changed)


def test_the_example_s_link_lengths_are_under_the_key(arm_run, at_repo, monkeypatch):
    """The arm's link lengths live in its kinematics module, not in a task field: changing them
    changes what the task does, so its demos and every stage after them are stale, and the log names
    the probes that saw it: forward kinematics and the demos (its environment steps in joint space,
    which the links do not change)."""
    task, preset = tasks.get_task(SPEC), get_preset("tiny")
    folder = arm_run / "planar_arm"
    names = [s.name for s in plan_stages(task, preset, folder)]
    kinematics = importlib.import_module("examples.planar_arm.kinematics")
    monkeypatch.setattr(kinematics, "LINKS", kinematics.LINKS * np.array([1.0, 1.0, 0.9]))
    moved = replace(task)  # the same fields, a new object: its key is computed again
    stale = pending(plan_stages(moved, preset, folder))
    assert [name for name, _ in stale] == names and "demos" in names
    assert explain({"task": task_key(task)}, {"task": task_key(moved)}) == ["task (probe demos; probe task_space)"]


def test_the_example_plans_evaluates_exports_and_serves(arm_run, at_repo, tmp_path, capsys):
    ckpt = tmp_path / "ckpt"
    shutil.copytree(arm_run / "planar_arm" / "checkpoints", ckpt)
    out = tmp_path / "plan.json"
    assert main(["plan", "--task", SPEC, "--checkpoints", str(ckpt), "--goals", *GOALS, "--target", "1",
                 "--method", "scdp", "--seed", "3", "--out", str(out)]) == 0
    traj = json.loads(out.read_text())
    assert traj["target"] == 1 and np.asarray(traj["states"]).shape[1] == 3 and np.asarray(traj["path"]).shape[1] == 2
    assert main(["evaluate", "--task", SPEC, "--checkpoints", str(ckpt), "--scenes", "2", "--methods", "dp", "scdp",
                 "--out", str(tmp_path / "eval.json")]) == 0
    assert main(["export", "--task", SPEC, str(ckpt)]) == 0
    assert (ckpt / "base" / "model.onnx").is_file()
    service = PlanningService(ckpt, SPEC, batching=BatchingOptions(max_wait_ms=1.0))
    with TestClient(create_app(service)) as client:
        assert client.get("/v1/info").json()["task"] == "planar_arm"
        body = {"state_history": [[1.4, -1.9, -1.6]], "goals": [[0.6, 0.12], [0.6, -0.12]], "target": 0,
                "method": "scdp", "seed": 3}
        response = client.post("/v1/act", json=body)
        # the tiny nets may plan beyond the arm's reach, which the task's own guard rail refuses
        assert response.status_code == 200 or response.json()["error"].startswith("actions: "), response.text
        outside = client.post("/v1/act", json={**body, "state_history": [[1.4, -3.5, -1.6]]})
        assert outside.status_code == 422 and "elbow = -3.5 is outside the planar_arm bounds" in outside.json()["error"]


def test_the_example_makes_a_study_that_a_new_process_reads(arm_run, at_repo, tmp_path):
    out = tmp_path / "study"
    assert main(["study", "make", "--task", SPEC, "--checkpoints", str(arm_run / "planar_arm" / "checkpoints"),
                 "--methods", "dp", "scdp", "--scenes", "2", "--attention", "1", "--duration-s", "1", "--out", str(out)]) == 0
    study = read_study(out)
    assert study.task == SPEC and {s.view.kind for s in study.stimuli.values()} == {"top"}
    tasks._LOADED.clear()
    assert tasks.get_task(study.task).name == "planar_arm"


def _h5(path, episodes, states=None):
    with h5py.File(path, "w") as f:
        for i, ep in enumerate(episodes):
            order = [ep["target"]] + [k for k in range(len(ep["goals"])) if k != ep["target"]]  # target first
            f[f"data/demo_{i}/states"] = ep["state"] if states is None else states
            f[f"data/demo_{i}/actions"] = ep["action"]
            f[f"data/demo_{i}/obs/object"] = np.repeat(np.asarray(ep["goals"])[order].reshape(1, -1), len(ep["state"]), 0)


def test_the_example_s_recordings_import_and_train_and_bad_ones_are_refused(arm_run, at_repo, tmp_path, capsys):
    demos = DemoDataset.load(arm_run / "planar_arm" / "demos.zarr")
    episodes = [demos.episode(i) for i in range(len(demos.episode_ends))]  # the tiny preset's 8
    _h5(tmp_path / "arm.hdf5", episodes)
    assert main(["import-hdf5", str(tmp_path / "arm.hdf5"), "--task", SPEC, "--out", str(tmp_path / "arm.zarr")]) == 0
    imported = DemoDataset.load(tmp_path / "arm.zarr")
    assert imported.task == "planar_arm" and len(imported.episode_ends) == len(episodes)
    assert imported.attrs["task_reference"] == SPEC  # a new process finds the task from the data alone
    assert main(["train", "base", "--task", SPEC, "--data", str(tmp_path / "arm.zarr"), "--preset", "tiny",
                 "--out", str(tmp_path / "base")]) == 0
    assert (tmp_path / "base" / "model.safetensors").is_file()
    capsys.readouterr()
    bent = episodes[0]["state"].copy()
    bent[5, 1] = 3.2  # the elbow past its joint limit (2.8 rad, 2.85 with the reporting margin)
    _h5(tmp_path / "bad.hdf5", episodes[:1], states=bent)
    assert main(["import-hdf5", str(tmp_path / "bad.hdf5"), "--task", SPEC, "--out", str(tmp_path / "bad.zarr")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["scdp: error: data/demo_0/states: step 5: elbow = 3.2 is outside the planar_arm bounds -2.85..2.85"]
    assert not (tmp_path / "bad.zarr").exists()
