"""`scdp study analyze`: who is left out and why, what kind of data it is, and the statistics."""

import csv
import io
import json

import numpy as np
import pytest
from fastapi.testclient import TestClient

from helpers.studies import Clock, enrol, synthetic_study, take_study
from helpers.studies import trials_of as analysis_trials
from scdp.cli import main
from scdp.evaluation.resampling import crossed_weights
from scdp.study import analysis
from scdp.study.app import create_app
from scdp.study.make import read_study
from scdp.study.store import Store, database_url


def _collect(folder, participants):
    """Each (pid, options) takes the whole study through the API on a driven clock."""
    study = read_study(folder)
    store, clock = Store(database_url(folder)), Clock()
    app = create_app(study, folder, store, clock=clock)
    for pid, options in participants:
        client = TestClient(app)
        reload_at = options.pop("reload", False)
        if reload_at:  # one reload during the first motion
            enrol(client, pid)
            client.post("/api/motion", json={"pid": pid, "trial": 0})
            client.post("/api/state", json={"pid": pid})
        take_study(client, store, clock, pid, study, **options)
        clock.now += 5.0
    return study, store


def test_exclusions_carry_their_reasons_and_a_mixed_database_says_so_first(tmp_path):
    synthetic_study(tmp_path / "s")
    honest = [(f"p{i}", {}) for i in range(4)]
    odd = [("slowed", {"lag": 0.3}), ("replayer", {"reload": True}), ("hasty", {"confirm_after": 0.0}),
           ("careless", {"correct": False}), ("SIM-001", {}), ("SIM-002", {})]
    study, store = _collect(tmp_path / "s", honest + odd)
    assert main(["study", "analyze", "--study", str(tmp_path / "s"), "--out", str(tmp_path / "a")]) == 0
    report = (tmp_path / "a" / "report.md").read_text()
    assert report.splitlines()[0].startswith("# MIXED DATABASE: 8 people and 2 simulated participants")
    assert "**Small sample**" in report
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    reasons = summary["excluded"]
    assert set(reasons) == {"slowed", "replayer", "hasty", "careless", "SIM-001", "SIM-002"}
    assert reasons["slowed"][0].startswith("playback") and reasons["replayer"][0].startswith("replays")
    assert reasons["hasty"][0].startswith("too fast") and reasons["SIM-001"][0].startswith("simulated")
    assert any(r.startswith("attention") for r in reasons["careless"])
    assert summary["analysed_participants"] == 4 and summary["data"] == "mixed"
    assert summary["interaction"] and {c["quantity"] for c in summary["interaction"]} >= {"final"}
    table = list(csv.DictReader(io.StringIO((tmp_path / "a" / "participants.csv").read_text())))
    assert len(table) == 10 and {r["pid"]: r["replays"] for r in table}["replayer"] == "2"  # the reload and take_study's own state call
    responses = list(csv.DictReader(io.StringIO((tmp_path / "a" / "responses.csv").read_text())))
    assert responses[0]["confirmed_utc"].endswith("+00:00") and responses[0]["served_utc"] <= responses[0]["played_utc"]
    for pid in reasons:  # every excluded participant is in the report's table with its reason
        assert f"| {pid} |" in report


def test_a_database_of_simulated_participants_only_is_labelled_simulated(tmp_path):
    synthetic_study(tmp_path / "s")
    _collect(tmp_path / "s", [("SIM-001", {}), ("SIM-002", {})])
    assert main(["study", "analyze", "--study", str(tmp_path / "s"), "--out", str(tmp_path / "a")]) == 0
    report = (tmp_path / "a" / "report.md").read_text()
    assert report.splitlines()[0].startswith("# SIMULATED DATA")
    assert json.loads((tmp_path / "a" / "summary.json").read_text())["analysed_participants"] == 2


def test_screening_rules_come_from_the_study(tmp_path):
    synthetic_study(tmp_path / "s", screening=dict(max_replays=2, max_lag=0.5))
    _collect(tmp_path / "s", [("slowed", {"lag": 0.3}), ("replayer", {"reload": True})])
    assert main(["study", "analyze", "--study", str(tmp_path / "s"), "--out", str(tmp_path / "a")]) == 0
    assert json.loads((tmp_path / "a" / "summary.json").read_text())["excluded"] == {}


def test_response_quantities_by_hand():
    events = [{"t": 0.1, "goal": 1}, {"t": 0.4, "goal": 0}, {"t": 0.6, "goal": 1}, {"t": 0.8, "goal": 0}]
    curve = analysis.correct_curve(events, 0, grid=np.array([0.0, 0.1, 0.5, 0.7, 0.8, 1.0]))
    assert curve.tolist() == [0, 0, 1, 0, 1, 1]
    assert analysis.kept_time(events, 0) == 0.8 and analysis.kept_time(events, 1) == 1.0
    assert analysis.kept_time([{"t": 0.2, "goal": 2}, {"t": 0.5, "goal": 2}], 2) == 0.2
    assert analysis.changes_of_mind(events) == 3 and analysis.changes_of_mind(events[:1]) == 0


def test_motions_play_at_one_speed_and_the_analysis_reads_their_duration_and_time(tmp_path):
    """scdp's paths have 70 points, dp's 40: at the study's one speed scdp's motions last 69/39 as long. The
    server holds a Confirm until each motion's own end; the analysis reports each method's duration (a
    covariate, with its paired difference) and the accuracy at seconds of motion beside fractions."""
    study = synthetic_study(tmp_path / "s", points={"scdp": 70})
    assert study.point_s == pytest.approx(1.0 / 54)  # the median main motion (39 and 69 steps) lasts duration_s
    assert {m: study.motion_s(f"main-ambiguous-000-0-{m}") for m in ("dp", "scdp")} == pytest.approx(
        {"dp": 39 / 54, "scdp": 69 / 54})
    store, clock = Store(database_url(tmp_path / "s")), Clock()
    c = TestClient(create_app(study, tmp_path / "s", store, clock=clock))
    state = enrol(c, "early")
    while study.stimuli[analysis_trials(store, study, "early")[state["trial"]["index"]].stimulus].method != "scdp":
        index = state["trial"]["index"]
        c.post("/api/motion", json={"pid": "early", "trial": index})
        clock.now += 0.3
        c.post("/api/pick", json={"pid": "early", "trial": index, "goal": 0, "t": 0.3})
        clock.now += 1.0
        state = c.post("/api/response", json={"pid": "early", "trial": index, "confidence": 3}).json()
    index = state["trial"]["index"]  # an scdp motion: 1.28 s
    c.post("/api/motion", json={"pid": "early", "trial": index})
    clock.now += 0.3
    c.post("/api/pick", json={"pid": "early", "trial": index, "goal": 0, "t": 0.3})
    clock.now += 0.9  # 1.2 s: long past dp's end, not yet scdp's
    r = c.post("/api/response", json={"pid": "early", "trial": index, "confidence": 3})
    assert r.status_code == 422 and r.json()["error"] == "trial: the motion of trial %d is still playing" % index
    study, _ = _collect(tmp_path / "s", [(f"p{k}", {"at": 0.6, "duration": 1.3}) for k in range(4)])
    out = tmp_path / "a"
    assert main(["study", "analyze", "--study", str(tmp_path / "s"), "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    block = summary["sets"]["ambiguous"]
    assert block["methods"]["dp"]["duration_s"]["mean"] == pytest.approx(39 / 54)
    assert block["methods"]["scdp"]["duration_s"]["mean"] == pytest.approx(69 / 54)
    duration = next(p for p in block["paired"] if p["quantity"] == "duration_s")
    assert (duration["a"], duration["b"]) == ("dp", "scdp") and duration["mean"] == pytest.approx(-30 / 54)
    assert duration["excludes_zero"]
    # every pick came 0.6 s into the motion: correct at 1 s for either method, whatever its length
    for m in ("dp", "scdp"):
        assert block["methods"][m]["correct_at_1s"]["mean"] == 1.0
    rows = list(csv.DictReader(io.StringIO((out / "responses.csv").read_text())))
    assert {round(float(r["first_pick_s"]), 3) for r in rows if r["kind"] == "main"} == {0.6}


def test_the_crossed_bootstrap_resamples_participants_and_scenes_as_clusters():
    # one scene: the weights are the participants' draw counts, shared by all of a participant's responses
    w = crossed_weights(np.array(["a", "a", "b", "c"]), np.array(["s"] * 4), samples=400, seed=3)
    assert np.all(w[:, 0] == w[:, 1]) and np.all(w[:, [0, 2, 3]].sum(axis=1) == 3)
    assert np.any(w[:, 0] != w[:, 2])
    # one participant: the weights are the scenes' draw counts
    w = crossed_weights(np.array(["a"] * 4), np.array(["s1", "s1", "s2", "s3"]), samples=400, seed=3)
    assert np.all(w[:, 0] == w[:, 1]) and np.all(w[:, [0, 2, 3]].sum(axis=1) == 3)
    # both: a response's weight is the product of its participant's and its scene's counts
    w = crossed_weights(np.array(["a", "a", "b", "b"]), np.array(["s1", "s2", "s1", "s2"]), samples=400, seed=3)
    assert np.all(w[:, 0] * w[:, 3] == w[:, 1] * w[:, 2])
    assert w.mean(axis=0) == pytest.approx([1.0] * 4, abs=0.2)  # E[count_p * count_s] = 1


def test_a_pair_the_button_adjustment_cannot_take_is_named_with_why():
    from scdp.study.covariates import position_checks
    used = [{"choice_position": p, "target_position": p, "final": 1.0, "method": m}
            for m, targets in (("dp", (0, 1, 0, 1)), ("scdp", (0, 0, 0, 0))) for p in targets]
    checks = position_checks(used, np.ones((10, len(used))), 2, ["dp", "scdp"])
    assert checks["adjusted_final"] == []
    assert checks["dropped"] == [{"a": "dp", "b": "scdp",
                                  "why": "no response in scdp × button 1: the adjustment needs every cell"}]
