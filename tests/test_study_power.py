"""Sizing a study before anyone is paid: the offline simulated person and ``scdp study power``."""

import json

import numpy as np
import pytest
from fastapi.testclient import TestClient

from helpers.studies import Clock, synthetic_study, take_study
from scdp.cli import main
from scdp.study import api_participant
from scdp.study.app import create_app
from scdp.study.person import ParticipantModel
from scdp.study.power import PowerSettings, power
from scdp.study.screening import participant_table
from scdp.study.store import Store, database_url


@pytest.mark.parametrize("commit", [0.0, 0.7])
def test_offline_picks_follow_the_page_participant_s_rule(tmp_path, commit):
    """The vectorised picks of ParticipantModel.picks are the clicks the page participant's look-by-look rule
    (ParticipantModel.decide on the latest look delay_s old) makes, for 50 trials' random misjudgements; the last
    click is where the motion stopped (a person sees the end)."""
    study = synthetic_study(tmp_path / "s", bends=(0.5, -0.6))
    model = ParticipantModel(commit=commit)
    rng = np.random.default_rng(0)
    for sid in study.ids("main"):
        stim = study.stimuli[sid]
        looks, beliefs = model.sights(stim.path, stim.goals, study.point_s)
        for _ in range(50 // len(study.ids("main")) + 1):
            offsets = 0.8 * rng.standard_normal(2)
            picked, loop = None, []
            for s, b in zip(looks, beliefs):
                if np.isnan(b[0]):
                    continue
                p = model.noisy(b, offsets)
                k = int(np.argmax(p))
                if p[k] >= commit and k != picked:
                    loop.append((float(s), k))
                    picked = k
            events = model.picks(looks, beliefs, offsets, model.belief(stim.path, stim.goals))
            assert [(e["s"], e["goal"]) for e in events] == loop
            end = int(np.argmin(np.linalg.norm(np.asarray(stim.goals) - stim.path[-1], axis=1)))
            assert events[-1]["goal"] == end and events[-1]["s"] <= study.motion_s(sid) + 1e-9
        assert looks[0] == pytest.approx(model.look_s) and np.isnan(beliefs[0]).all()  # nothing seen before delay_s


def test_power_grows_with_participants_and_the_recommendation_is_the_first_size_reaching_it(tmp_path):
    """scdp's paths bow away from the other goal, dp's head straight: at 25 % of the motion people read scdp's
    better. With 6 + 6 scenes of 6 s motions, 4 participants rarely show it and 80 nearly always do."""
    study = synthetic_study(tmp_path / "s", scenes_per_set=6, duration_s=6.0, bends=(0.0, 0.6))
    settings = PowerSettings(quantity="correct_at_25", participants=(4, 80), replicates=40, samples=200)
    result = power(study, settings)
    small, large = result["sizes"]
    assert small["power"] < 0.5 <= 0.8 <= large["power"], result["sizes"]
    assert large["difference"] > 0.1 and result["recommended"] == 80
    assert power(study, PowerSettings(quantity="correct_at_25", participants=(4,), replicates=40,
                                      samples=200))["recommended"] is None


def test_pilot_answers_are_drawn_from_the_pilot_s_own_responses(tmp_path):
    """Two pilot participants pick the target at 2 s of every 6 s motion: drawn from them, scdp and dp are equally
    right at 50 % (power 0); the simulated person sees scdp's lead."""
    study = synthetic_study(tmp_path / "s", scenes_per_set=6, duration_s=6.0, bends=(0.0, 0.6))
    store, clock = Store(database_url(tmp_path / "s")), Clock()
    client = TestClient(create_app(study, tmp_path / "s", store, clock=clock))
    for pid in ("p1", "p2"):
        take_study(client, store, clock, pid, study, at=2.0, duration=study.motion_s(study.ids("main")[0]))
    args = ["study", "power", "--study", str(tmp_path / "s"), "--quantity", "correct_at_50", "--participants", "40",
            "--replicates", "20", "--samples", "200"]
    assert main([*args, "--pilot", "--out", str(tmp_path / "pilot.md")]) == 0
    pilot = json.loads((tmp_path / "pilot.json").read_text())
    assert pilot["sizes"][0]["difference"] == 0.0 and pilot["sizes"][0]["power"] == 0.0
    assert main([*args, "--out", str(tmp_path / "model.md")]) == 0
    assert json.loads((tmp_path / "model.json").read_text())["sizes"][0]["power"] > 0.5
    assert "participants" in (tmp_path / "model.md").read_text()


@pytest.mark.parametrize("extra,message", [
    (["--a", "ld"], "--a: 'ld' is not a method of this study (dp, scdp)"),
    (["--participants", "5"], "--participants: sizes are multiples of the 2 methods"),
    (["--quantity", "changes"], "--quantity: must be one of final, t_kept"),
    (["--pilot"], "--pilot: the database holds no analysed main response"),
])
def test_power_refuses_bad_input_in_one_line(tmp_path, capsys, extra, message):
    synthetic_study(tmp_path / "s")
    assert main(["study", "power", "--study", str(tmp_path / "s"), "--replicates", "10", *extra,
                 "--out", str(tmp_path / "p.md")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"scdp: error: {message}") and "\n" not in err, err
    assert not (tmp_path / "p.md").exists()


def test_power_does_not_overwrite_a_report_without_force(tmp_path, capsys):
    synthetic_study(tmp_path / "s")
    (tmp_path / "p.md").write_text("kept")
    args = ["study", "power", "--study", str(tmp_path / "s"), "--replicates", "10", "--participants", "2",
            "--out", str(tmp_path / "p.md")]
    assert main(args) == 2 and "already exists" in capsys.readouterr().err
    assert (tmp_path / "p.md").read_text() == "kept"
    assert main([*args, "--force"]) == 0 and (tmp_path / "p.json").exists()


def test_the_api_participant_clicks_as_the_offline_person_does_and_is_analysed(tmp_path):
    """Without noise the person's rule has one answer per motion: the participant that takes the study through
    the HTTP API (scdp study simulate --no-browser) stores, trial by trial, the clicks ParticipantModel.watch
    makes offline on the same stimulus (goal and second), whatever the mirror and the goal order; two runs with
    one seed store the same clicks; every participant is analysed."""
    model = ParticipantModel(noise=0.0)
    stored = []
    for run in ("a", "b"):
        study = synthetic_study(tmp_path / run, duration_s=3.0, bends=(0.0, -0.6))  # scdp's paths head the wrong way first
        store = Store(database_url(tmp_path / run))
        assert api_participant.simulate(study, tmp_path / run, store, 2, model=model, seed=5) == ["DONE42"] * 2
        rows = sorted(store.rows(), key=lambda r: (r["pid"], r["trial"]))
        stored.append([[(e["t"], e["goal"]) for e in r["events"]] for r in rows])
        for r in rows:
            if r["kind"] in ("main", "attention"):
                stim = study.stimuli[r["stimulus"]]
                offline = model.watch(stim.path, stim.goals, study.point_s, np.random.default_rng(0))
                assert [(round(e["s"], 6), e["goal"]) for e in offline] == [
                    (round(e["t"] * study.motion_s(r["stimulus"]), 6), e["goal"]) for e in r["events"]], r["stimulus"]
        people = participant_table(study, store.participants(), store.rows())
        assert all(p["analysed"] for p in people), [p["reasons"] for p in people]
    assert stored[0] == stored[1]
