"""`scdp study`: the design, the page's contract, a real browser, a killed server, and the analysis."""

import json
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import time

import httpx
import numpy as np
import pytest
from fastapi.testclient import TestClient
from playwright.sync_api import sync_playwright

from scdp.cli import main
from scdp.study import analysis
from scdp.study.app import create_app
from scdp.study.design import ATTENTION, MAIN, PRACTICE, assignment, served_trial
from scdp.study.make import read_study
from scdp.study.participant import ParticipantModel, ServerThread, launch_browser, simulate, wait_screen
from scdp.study.store import Store, database_url

METHODS = ["dp", "scdp"]


def _make(tiny, out, task, extra=()):
    ckpt = tiny / task / "checkpoints"
    return main(["study", "make", "--task", task, "--checkpoints", str(ckpt), "--methods", *METHODS, "--scenes", "2",
                 "--attention", "1", "--duration-s", "1", "--frames", "4", "--completion-code", "DONE42",
                 "--out", str(out), *extra])


@pytest.fixture(scope="module")
def nav_study(tiny_reproduction, tmp_path_factory):
    out = tmp_path_factory.mktemp("study") / "nav"
    assert _make(tiny_reproduction, out, "navigation") == 0
    return out


@pytest.fixture
def fresh_study(nav_study, tmp_path):
    """A copy of the navigation study with an empty database."""
    import shutil

    return shutil.copytree(nav_study, tmp_path / "s")


def test_make_rolls_every_method_out_on_the_same_scenes(nav_study, tiny_reproduction, tmp_path, capsys):
    study = read_study(nav_study)
    stimuli = study["stimuli"]
    main_ids = [k for k, v in stimuli.items() if v["kind"] == MAIN]
    assert len(main_ids) == len(METHODS) * 2 * 2  # methods x (2 ambiguous + 2 clear)
    assert sum(v["kind"] == PRACTICE for v in stimuli.values()) == 1
    assert sum(v["kind"] == ATTENTION for v in stimuli.values()) == 1
    for scene_set in ("ambiguous", "non_ambiguous"):
        for i in range(2):
            same = [stimuli[f"main-{scene_set}-{i:03d}-{m}"] for m in METHODS]
            assert all(s["goals"] == same[0]["goals"] and s["target"] == same[0]["target"] for s in same)
            assert same[0]["path"][0] == same[1]["path"][0]  # the same start noise
    assert study["checkpoint_sha256"] and study["config"]["completion_code"] == "DONE42"
    # the same command makes the same study
    assert _make(tiny_reproduction, tmp_path / "again", "navigation") == 0
    again = read_study(tmp_path / "again")
    assert again["stimuli"] == study["stimuli"] and again["scenes"] == study["scenes"]
    capsys.readouterr()
    assert _make(tiny_reproduction, nav_study, "navigation") == 2
    assert "already exists" in capsys.readouterr().err


def test_block_reach_stimuli_are_frames_from_a_person_s_view(tiny_reproduction, tmp_path):
    assert _make(tiny_reproduction, tmp_path / "br", "block_reach") == 0
    study = read_study(tmp_path / "br")
    stim = next(v for v in study["stimuli"].values() if v["kind"] == MAIN)
    view = stim["view"]
    assert view["kind"] == "camera" and len(view["frames"]) == 4
    assert all((tmp_path / "br" / "stimuli" / f).stat().st_size > 1000 for f in view["frames"])
    px = np.array(view["path_px"])
    assert len(px) == len(stim["path"]) and np.all((px >= 0) & (px < [view["width"], view["height"]]))
    from scdp.study.design import Trial

    flipped = served_trial(study, Trial(1, next(k for k, v in study["stimuli"].items() if v is stim), MAIN, True, [0, 1]), 9)
    assert np.allclose(np.array(flipped["view"]["goals_px"])[:, 0], view["width"] - 1 - np.array(view["goals_px"])[:, 0])
    assert np.allclose(np.array(flipped["view"]["path_px"]), np.c_[view["width"] - 1 - px[:, 0], px[:, 1]])
    assert np.allclose(np.array(flipped["goals"])[:, 1], -np.array(stim["goals"])[:, 1]) and flipped["view"]["flip"]


def test_the_latin_square_balances_methods_over_scenes_and_participants(nav_study):
    study = read_study(nav_study)
    seen = {}
    for number in range(len(METHODS)):
        trials = assignment(study, number)
        assert trials[0].kind == PRACTICE and trials[1].kind != ATTENTION
        main_trials = [t for t in trials if t.kind == MAIN]
        scenes = [t.stimulus.rsplit("-", 1)[0] for t in main_trials]
        assert len(scenes) == len(set(scenes)) == 4  # every scene once
        methods = [study["stimuli"][t.stimulus]["method"] for t in main_trials]
        assert all(methods.count(m) == 2 for m in METHODS)  # every method equally often
        for t in main_trials:
            seen[t.stimulus] = seen.get(t.stimulus, 0) + 1
        assert assignment(study, number) == trials  # rebuilt exactly from the arrival number
    assert set(seen) == {k for k, v in study["stimuli"].items() if v["kind"] == MAIN} and set(seen.values()) == {1}
    draws = [t for n in range(8) for t in assignment(study, n)]
    assert {t.mirror for t in draws} == {True, False} and len({tuple(t.colours) for t in draws}) > 2


def _answer(client, pid, trial, goal, **kw):
    return client.post("/api/response", json={"pid": pid, "trial": trial, "events": [{"t": 0.5, "goal": goal}],
                                              "choice": goal, **kw})


def test_the_api_refuses_what_it_must_and_changes_nothing(fresh_study):
    study = read_study(fresh_study)
    store = Store(database_url(fresh_study))
    client = TestClient(create_app(study, fresh_study, store))
    assert client.post("/api/state", json={"pid": "p1"}).json()["screen"] == "consent"
    r = _answer(client, "p1", 0, 0)
    assert r.status_code == 422 and r.json()["error"].startswith("consent:")
    state = client.post("/api/consent", json={"pid": "p1"}).json()
    assert state["screen"] == "trial" and "target" not in json.dumps(state["trial"])  # the page never gets it
    bad = [({"pid": "p1", "trial": 0, "events": [], "choice": 0}, "events:"),
           ({"pid": "p1", "trial": 0, "events": [{"t": 2, "goal": 0}], "choice": 0}, "events:"),
           ({"pid": "p1", "trial": "x", "events": [{"t": 0, "goal": 0}], "choice": 0}, "trial:"),
           ({"pid": "p 1!", "trial": 0, "events": [{"t": 0, "goal": 0}], "choice": 0}, "pid:"),
           ({"pid": "p1", "trial": 0, "events": [{"t": 0, "goal": 0}], "choice": 0, "extra": 1}, "extra:")]
    for body, field in bad:
        r = client.post("/api/response", json=body)
        assert r.status_code == 422 and r.json()["error"].startswith(field) and "\n" not in r.json()["error"], (body, r.text)
    r = client.post("/api/response", content=b"{not json", headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["error"].startswith("body:")
    assert _answer(client, "p1", 0, 7).json()["error"].startswith("events:")  # no goal 7
    assert _answer(client, "p1", 3, 0).json()["error"] == "trial: p1 is at trial 0, got 3"
    assert _answer(client, "p1", 99, 0).json()["error"].startswith("trial: p1 was assigned trials 0 to")
    r = client.post("/api/response", json={"pid": "p1", "trial": 0, "events": [{"t": 0.1, "goal": 0}], "choice": 1})
    assert r.json()["error"].startswith("choice:")
    assert store.rows() == []  # nothing refused was stored
    assert _answer(client, "p1", 0, 1).status_code == 200
    before = store.rows()
    r = _answer(client, "p1", 0, 0)
    assert r.status_code == 409 and r.json()["error"] == "trial: trial 0 of p1 is already confirmed"
    assert store.rows() == before and before[0]["choice"] == 1  # the first answer stands


def test_a_person_in_chromium_takes_the_study_with_a_change_of_mind_and_a_refresh(fresh_study):
    study = read_study(fresh_study)
    store = Store(database_url(fresh_study))
    with ServerThread(create_app(study, fresh_study, store)) as url, sync_playwright() as pw:
        browser = launch_browser(pw)
        page = browser.new_page(viewport={"width": 390, "height": 844})  # a phone
        page.goto(f"{url}/?pid=alice&rate=4")
        wait_screen(page, ("consent",))
        assert page.is_disabled("#consent-go")
        page.check("#consent-box")
        page.click("#consent-go")
        wait_screen(page, ("instructions",))
        page.click("#instructions-go")
        n_trials = len(assignment(study, 0))
        for trial in range(n_trials):
            s = wait_screen(page, ("trial",), after_index=trial - 1)
            assert s["index"] == trial
            if trial == 2:  # a refresh in the middle of a trial resumes that trial
                page.reload()
                assert wait_screen(page, ("trial",))["index"] == 2
            page.click("#goal-0")
            if trial == 1:  # a change of mind
                page.click("#goal-1")
            page.wait_for_function("window.study.done")
            page.click("#confirm")
        wait_screen(page, ("done",))
        assert page.text_content("#done-code") == "DONE42"
        page.reload()  # finished: a refresh shows the code again, no trial
        assert wait_screen(page, ("done",))["screen"] == "done"
        browser.close()
    rows = store.rows()
    assert [r["trial"] for r in rows] == list(range(n_trials)) and all(r["pid"] == "alice" for r in rows)
    assert [e["goal"] for e in rows[1]["events"]] == [0, 1] and rows[1]["choice"] == 1
    assert rows[1]["events"][0]["t"] <= rows[1]["events"][1]["t"] <= 1
    assert rows[-1]["participant_completed"] is not None and rows[0]["kind"] == PRACTICE
    for r in rows:  # correctness is the server's, from the stimulus it assigned
        assert r["correct"] == (r["choice"] == study["stimuli"][r["stimulus"]]["target"])


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(folder, port):
    proc = subprocess.Popen([sys.executable, "-m", "scdp", "study", "serve", "--study", str(folder), "--port", str(port)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert "serving" in proc.stdout.readline()
    for _ in range(500):
        try:
            httpx.get(f"http://127.0.0.1:{port}/", timeout=1)
            return proc
        except httpx.TransportError:
            time.sleep(0.02)
    raise AssertionError("the server did not answer")


def test_a_kill_9_between_two_trials_loses_no_confirmed_answer(fresh_study):
    port = _free_port()
    url = f"http://127.0.0.1:{port}"
    proc = _start(fresh_study, port)
    try:
        httpx.post(f"{url}/api/consent", json={"pid": "bob"})
        for trial in range(2):
            assert httpx.post(f"{url}/api/response", json={"pid": "bob", "trial": trial, "choice": 1,
                                                           "events": [{"t": 0.3, "goal": 1}]}).status_code == 200
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    with sqlite3.connect(fresh_study / "responses.sqlite") as db:  # read by SQLite itself, not through scdp
        assert db.execute("select trial, choice from responses where pid='bob' order by trial").fetchall() == [(0, 1), (1, 1)]
    proc = _start(fresh_study, port)
    try:
        state = httpx.post(f"{url}/api/state", json={"pid": "bob"}).json()
        assert state["answered"] == 2 and state["trial"]["index"] == 2
    finally:
        proc.terminate()
        proc.wait()


def test_simulated_participants_answer_through_the_page_and_are_analysed(fresh_study, tmp_path):
    study = read_study(fresh_study)
    store = Store(database_url(fresh_study))
    codes = simulate(create_app(study, fresh_study, store), study, 3,
                     model=ParticipantModel(noise=0.0, delay_s=0.0, look_s=0.02))
    assert codes == ["DONE42"] * 3
    rows = store.rows()
    assert len(rows) == 3 * len(assignment(study, 0)) and all(r["pid"].startswith("SIM-") for r in rows)
    assert all(r["rate"] == 1.0 for r in rows)
    assert main(["study", "analyze", "--study", str(fresh_study), "--out", str(tmp_path / "a")]) == 0
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["simulated"] and summary["participants"] == 3
    report = (tmp_path / "a" / "report.md").read_text()
    assert "Simulated data" in report and (tmp_path / "a" / "accuracy.png").stat().st_size > 0
    csv_rows = (tmp_path / "a" / "responses.csv").read_text().strip().splitlines()
    assert len(csv_rows) == 1 + len(rows)
    # a noiseless participant without delay is the path-length observer (up to how often it looks)
    gaps = [v["gap_to_path_length_observer"] for b in summary["sets"].values() for v in b["methods"].values()]
    assert len(gaps) == 4 and max(gaps) < 0.1, gaps
    assert main(["study", "delete", "--study", str(fresh_study), "--participant", "SIM-002"]) == 0
    assert {r["pid"] for r in store.rows()} == {"SIM-001", "SIM-003"}


def test_response_quantities_by_hand():
    events = [{"t": 0.1, "goal": 1}, {"t": 0.4, "goal": 0}, {"t": 0.6, "goal": 1}, {"t": 0.8, "goal": 0}]
    curve = analysis.correct_curve(events, 0, grid=np.array([0.0, 0.1, 0.5, 0.7, 0.8, 1.0]))
    assert curve.tolist() == [0, 0, 1, 0, 1, 1]
    assert analysis.kept_time(events, 0) == 0.8 and analysis.kept_time(events, 1) == 1.0
    assert analysis.kept_time([{"t": 0.2, "goal": 2}, {"t": 0.5, "goal": 2}], 2) == 0.2
    assert analysis.changes_of_mind(events) == 3 and analysis.changes_of_mind(events[:1]) == 0


def test_the_crossed_bootstrap_resamples_participants_and_scenes_as_clusters():
    # one scene: the weights are the participants' draw counts, shared by all of a participant's responses
    w = analysis.crossed_weights(np.array(["a", "a", "b", "c"]), np.array(["s"] * 4), samples=400, seed=3)
    assert np.all(w[:, 0] == w[:, 1]) and np.all(w[:, [0, 2, 3]].sum(axis=1) == 3)
    assert np.any(w[:, 0] != w[:, 2])
    # one participant: the weights are the scenes' draw counts
    w = analysis.crossed_weights(np.array(["a"] * 4), np.array(["s1", "s1", "s2", "s3"]), samples=400, seed=3)
    assert np.all(w[:, 0] == w[:, 1]) and np.all(w[:, [0, 2, 3]].sum(axis=1) == 3)
    # both: a response's weight is the product of its participant's and its scene's counts
    w = analysis.crossed_weights(np.array(["a", "a", "b", "b"]), np.array(["s1", "s2", "s1", "s2"]), samples=400, seed=3)
    assert np.all(w[:, 0] * w[:, 3] == w[:, 1] * w[:, 2])
    assert w.mean(axis=0) == pytest.approx([1.0] * 4, abs=0.2)  # E[count_p * count_s] = 1
