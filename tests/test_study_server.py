"""The study server's rules, on a hand-made study and a clock the test drives: sessions, timing,
replays, what the page may receive, Latin-square rows over consenters, the body cap."""

import json

import numpy as np
import pytest
from fastapi.testclient import TestClient

from helpers.studies import Clock, enrol, rate_all, synthetic_study, take_study, take_trial, trials_of
from scdp.study.app import SESSION_COOKIE, create_app
from scdp.study.design import PALETTE, assignment, motion, served_trial
from scdp.study.make import read_study
from scdp.study.record import StudyConfig
from scdp.study.store import Store, database_url


@pytest.fixture
def served(tmp_path):
    """(study, store, clock, client factory) over a fresh synthetic study."""
    synthetic_study(tmp_path / "s")
    study = read_study(tmp_path / "s")
    store, clock = Store(database_url(tmp_path / "s")), Clock()
    app = create_app(study, tmp_path / "s", store, clock=clock)
    return study, store, clock, lambda: TestClient(app)


def test_the_page_receives_no_target_method_or_scene_before_the_answer(served):
    study, store, clock, client = served
    c = client()
    state = enrol(c, "p1")
    seen = []
    positions = []
    while state["screen"] == "trial":
        trial = state["trial"]
        spec = trials_of(store, study, "p1")[trial["index"]]
        stim = study.stimuli[spec.stimulus]
        text = json.dumps(state)
        leaks = ["target", "path", "frames", stim.method, spec.stimulus, "attention", "main", "instructed", "note"]
        if spec.kind != "practice":  # the page may say "practice"; nothing else about the trial
            leaks += [stim.scene_set, "practice"]
        for leak in leaks:
            assert leak not in text, (leak, text)
        m = c.post("/api/motion", json={"pid": "p1", "trial": trial["index"]}).json()
        # at the start the page holds the motion up to the study's lookahead_s only, never its end
        assert m["t"] == 0.0 and not m["done"] and len(m["path"]) == int(np.ceil(study.config.lookahead_s / study.point_s)) + 1
        assert stim.method not in json.dumps(m) and "target" not in json.dumps(m) and "note" not in m
        seen.append(np.asarray(trial["goals"]))
        positions.append((spec.kind, spec.order.index(stim.target)))
        r = take_trial(c, clock, "p1", trial["index"])
        state = r.json()
    # both buttons carry the target (their balance is across participants: tests/test_study_rules.py)
    assert {p for _, p in positions} == {0, 1}
    # over a block of M x K consent numbers, each ambiguous scene's target is on every button equally often
    ambiguous = [t.order.index(study.stimuli[t.stimulus].target) for n in range(4) for t in assignment(study, n)
                 if study.stimuli[t.stimulus].scene_set == "ambiguous"]
    assert ambiguous.count(0) == ambiguous.count(1)


def test_a_bot_that_answers_at_once_is_refused(served):
    study, store, clock, client = served
    c = client()
    state = enrol(c, "bot")
    index = state["trial"]["index"]
    m = c.post("/api/motion", json={"pid": "bot", "trial": index}).json()
    assert not m["done"] and "frames" not in m  # the end point is not there to read
    assert c.post("/api/pick", json={"pid": "bot", "trial": index, "goal": 0, "t": 0.0}).status_code == 200
    r = c.post("/api/response", json={"pid": "bot", "trial": index, "confidence": 5})
    assert r.status_code == 422 and r.json()["error"].startswith("trial: the motion of trial 0 is still playing")
    # claiming to have seen more of the motion than was served is refused too
    r = c.post("/api/pick", json={"pid": "bot", "trial": index, "goal": 1, "t": 0.9})
    assert r.status_code == 422 and r.json()["error"].startswith("t: 0.900 s of the motion had not been served")
    assert store.rows() == []
    clock.now += 1.0
    assert c.post("/api/response", json={"pid": "bot", "trial": index, "confidence": 5}).status_code == 200


def test_an_id_alone_cannot_answer_for_anyone(served):
    study, store, clock, client = served
    alice, mallory = client(), client()
    state = enrol(alice, "alice")
    assert SESSION_COOKIE + "alice" in alice.cookies and state["screen"] == "trial"
    for route, body in (("/api/state", {"pid": "alice"}), ("/api/consent", {"pid": "alice"}),
                        ("/api/comprehension", {"pid": "alice", "answers": [0, 0, 0]}),
                        ("/api/motion", {"pid": "alice", "trial": 0}),
                        ("/api/pick", {"pid": "alice", "trial": 0, "goal": 0, "t": 0.0}),
                        ("/api/focus", {"pid": "alice", "trial": 0, "event": "blur"}),
                        ("/api/response", {"pid": "alice", "trial": 0, "confidence": 3}),
                        ("/api/ratings", {"pid": "alice", "ratings": []})):
        r = mallory.post(route, json=body)
        assert r.status_code == 403 and r.json()["error"].startswith("session: "), (route, r.text)
    mallory.cookies.set(SESSION_COOKIE + "alice", "guessed-token")
    assert mallory.post("/api/state", json={"pid": "alice"}).status_code == 403
    assert store.served("alice", 0)["loads"] == 1 and store.picks("alice", 0) == []  # nothing of mallory's stored
    assert take_trial(alice, clock, "alice", 0).status_code == 200


def test_a_reload_resumes_the_motion_and_is_counted_as_a_replay(served):
    study, store, clock, client = served
    c = client()
    enrol(c, "r1")
    c.post("/api/motion", json={"pid": "r1", "trial": 0})
    clock.now += 0.6
    state = c.post("/api/state", json={"pid": "r1"}).json()  # a reload at 60 % of the motion
    assert state["playing"] is True and state["trial"]["index"] == 0
    m = c.post("/api/motion", json={"pid": "r1", "trial": 0}).json()
    assert m["t"] == pytest.approx(0.6)  # resumed, not restarted
    assert store.served("r1", 0)["replays"] == 1
    clock.now += 0.5
    c.post("/api/pick", json={"pid": "r1", "trial": 0, "goal": 0, "t": 1.0})
    assert c.post("/api/response", json={"pid": "r1", "trial": 0, "confidence": 4}).json()["trial"]["index"] == 1
    assert store.rows()[0]["replays"] == 1 and store.rows()[0]["loads"] == 2


def test_rows_count_consenters_only_and_an_abandoned_slot_is_released(served):
    study, store, clock, client = served
    c = client()
    for i in range(200):  # drive-by IDs that never consent leave no trace
        assert c.post("/api/state", json={"pid": f"drive-by-{i}"}).json()["screen"] == "consent"
    assert store.participants() == []
    client().post("/api/consent", json={"pid": "a"})
    assert store.participant("a")["row"] == 0 and store.participant("a")["number"] == 0
    clock.now += 61 * 60  # a abandons: after the slot timeout, row 0 is free again
    client().post("/api/consent", json={"pid": "b"})
    client().post("/api/consent", json={"pid": "c"})
    assert [store.participant(p)["row"] for p in "bc"] == [0, 1]
    assert [store.participant(p)["number"] for p in "bc"] == [1, 2]


def test_what_a_slowed_or_hurried_page_sends_is_refused(served):
    study, store, clock, client = served
    c = client()
    enrol(c, "s1")
    c.post("/api/motion", json={"pid": "s1", "trial": 0})
    for body in ({"pid": "s1", "trial": 0, "goal": 0, "t": 0.1, "rate": 0.25},
                 {"pid": "s1", "trial": 0, "goal": 7, "t": 0.1}):
        r = c.post("/api/pick", json=body)
        assert r.status_code == 422 and "\n" not in r.json()["error"], r.text
    assert c.post("/api/pick", json={"pid": "s1", "trial": 0, "goal": 2, "t": 0.1}).json()["error"].startswith("goal:")


def test_bodies_over_the_cap_are_refused_before_they_are_read(served):
    study, store, clock, client = served
    c = client()
    big = b'{"pid": "' + b"x" * 100_000 + b'"}'
    r = c.post("/api/state", content=big, headers={"content-type": "application/json"})
    assert r.status_code == 413 and r.json()["error"].startswith("body: larger than the 16384 bytes")

    def chunks():  # no Content-Length: counted as it arrives
        for _ in range(40):
            yield b" " * 1024
    r = c.post("/api/state", content=chunks(), headers={"content-type": "application/json"})
    assert r.status_code == 413
    assert c.post("/api/state", json={"pid": "ok"}).status_code == 200


def test_the_end_of_the_study_gives_the_code_and_the_platform_redirect(tmp_path):
    synthetic_study(tmp_path / "s", completion_url="https://example.org/done?cc={code}")
    study = read_study(tmp_path / "s")
    store, clock = Store(database_url(tmp_path / "s")), Clock()
    c = TestClient(create_app(study, tmp_path / "s", store, clock=clock))
    state = take_study(c, store, clock, "fin", study, rate=False)
    assert state["screen"] == "ratings" and "code" not in state  # the code comes after the ratings
    state = c.post("/api/ratings", json={"pid": "fin", "ratings": [
        {"item": it["item"], "legible": 6, "predictable": 2} for it in state["items"]]}).json()
    assert state["screen"] == "done" and state["code"] == "DONE42"
    assert state["redirect"] == "https://example.org/done?cc=DONE42"
    rows = store.rows()
    assert len(rows) == len(assignment(study, 0, 0)) and rows[-1]["participant_completed"] is not None
    for r in rows:  # correctness is the server's, from the stimulus and the goal order it served
        told = r["kind"] == "instructed"
        assert r["correct"] and r["choice_position"] == (r["instructed"] if told else r["target_position"])
        assert r["confirmed"] - r["played"] == pytest.approx(1.5) and r["events"][0]["t"] == pytest.approx(0.3)
    assert sorted(x["method"] for x in store.ratings()) == ["dp", "scdp"]  # one rated motion per method
    r = c.post("/api/response", json={"pid": "fin", "trial": 0, "confidence": 3})
    assert r.status_code == 409 and r.json()["error"] == "trial: trial 0 of fin is already confirmed"


def test_block_reach_frames_are_revealed_as_the_motion_plays(tmp_path):
    study = synthetic_study(tmp_path / "s", camera=True, fps=10)  # a frame every 0.1 s of a 1 s motion: 11
    store, clock = Store(database_url(tmp_path / "s")), Clock()
    c = TestClient(create_app(read_study(tmp_path / "s"), tmp_path / "s", store, clock=clock))
    state = enrol(c, "v")
    assert "frames" not in json.dumps(state) and "path_px" not in json.dumps(state)
    all_frames = list(study.stimuli[trials_of(store, study, "v")[0].stimulus].view.frames)
    assert state["trial"]["view"]["poster"] == all_frames[0]  # the scene before Start: nothing has moved
    m = c.post("/api/motion", json={"pid": "v", "trial": 0}).json()
    assert StudyConfig().lookahead_s == 0.2 and len(all_frames) == 11  # the frames up to 0.2 s: 0..2 of 0..10, and not their count
    assert m["frames"] == all_frames[:3] and "n_frames" not in m
    assert c.get(f"/frames/{m['frames'][0]}").status_code == 200
    clock.now += 0.6  # 0.8 s of the motion may be the page's: frames 0..8
    assert c.post("/api/motion", json={"pid": "v", "trial": 0}).json()["frames"] == all_frames[:9]
    clock.now += 0.2
    assert c.post("/api/motion", json={"pid": "v", "trial": 0}).json()["frames"] == all_frames


# Every field the page receives, reviewed (issue 60): nothing may tell more than the motion shown so far.
ALLOWED = {
    "state": {"answered", "confidence", "n_trials", "picked", "pid", "playing", "screen", "task", "trial", "items",
              "scale", "statements", "feedback", "code", "redirect", "debrief", "retry", "attempts_left", "questions"},
    "trial": {"colours", "goals", "index", "kind", "n_trials", "point_s", "start", "task", "view"},  # design.TRIAL_FIELDS
    "view": {"flip", "fps", "goals_px", "height", "kind", "poster", "width"},
    "motion": {"trial", "t", "done", "ended", "path", "path_px", "frames", "note"},  # design.MOTION_FIELDS
    "pick": {"trial", "picked"}, "focus": {"trial", "counted"}, "feedback": {"correct", "colour"},
    "item": {"item", "motion", "trial"},
}


def _fields(kind: str, answer: dict) -> None:
    """``answer``'s keys, and those of every trial, view, motion and feedback inside it, are the allowed ones."""
    assert set(answer) <= ALLOWED[kind], (kind, set(answer) - ALLOWED[kind])
    for key, sub in (("trial", "trial"), ("feedback", "feedback"), ("motion", "motion")):
        if isinstance(answer.get(key), dict):
            _fields(sub, answer[key])
    if kind == "trial":
        _fields("view", answer["view"])
    for item in answer.get("items", []) if kind == "state" else ():
        _fields("item", item)


def test_every_answer_holds_only_the_reviewed_fields(tmp_path):
    """A participant through every route of a camera study: each answer's fields are the allowed ones, and
    before a motion is done its answer holds no more of the path than the server's clock plus the
    lookahead, whatever the stimulus's length."""
    study = synthetic_study(tmp_path / "s", camera=True, points={"scdp": 70}, completion_url="https://example.org/?cc={c}")
    store, clock = Store(database_url(tmp_path / "s")), Clock()
    c = TestClient(create_app(read_study(tmp_path / "s"), tmp_path / "s", store, clock=clock))
    _fields("state", c.post("/api/consent", json={"pid": "p"}).json())
    state = c.post("/api/comprehension", json={"pid": "p", "answers": [1, 0, 2]}).json()
    checked = 0
    while state["screen"] == "trial":
        _fields("state", state)
        index = state["trial"]["index"]
        duration = study.motion_s(trials_of(store, study, "p")[index].stimulus)
        m = c.post("/api/motion", json={"pid": "p", "trial": index}).json()
        _fields("motion", m)
        assert not m["done"] and len(m["path"]) == int(np.ceil(study.config.lookahead_s / study.point_s)) + 1  # any length: the same
        clock.now += 0.3
        _fields("pick", c.post("/api/pick", json={"pid": "p", "trial": index, "goal": 0, "t": 0.3}).json())
        _fields("focus", c.post("/api/focus", json={"pid": "p", "trial": index, "event": "blur"}).json())
        clock.now += duration
        _fields("motion", c.post("/api/motion", json={"pid": "p", "trial": index}).json())
        state = c.post("/api/response", json={"pid": "p", "trial": index, "confidence": 3}).json()
        checked += 1
    assert checked == 1 + 4 and state["screen"] == "ratings"  # the practice, 4 main trials (2 of them checks)
    _fields("state", state)
    _fields("state", rate_all(c, store, study, "p").json())
    _fields("state", c.post("/api/decline", json={"pid": "q"}).json())
    planted = {**m, "points": 40}
    with pytest.raises(AssertionError):
        _fields("motion", planted)  # a point count would be caught


def test_a_participant_s_trials_are_drawn_once_however_many_requests(tmp_path, monkeypatch):
    """A confirm reads the assignment twice (to check the trial, then for the next state), and every
    request after it again: the server draws a participant's trials once and reuses them."""
    import scdp.study.server as server

    draws = []
    real = server.assignment
    monkeypatch.setattr(server, "assignment", lambda *a: draws.append(a[1:]) or real(*a))
    synthetic_study(tmp_path / "s")
    study = read_study(tmp_path / "s")
    store, clock = Store(database_url(tmp_path / "s")), Clock()
    c = TestClient(create_app(study, tmp_path / "s", store, clock=clock))
    enrol(c, "p1")
    take_trial(c, clock, "p1", 0)
    take_trial(c, clock, "p1", 1)
    enrol(c, "p2")
    assert draws == [(0, 0), (1, 1)]  # one draw per participant: (consent number, row)


def test_camera_frames_come_no_faster_than_the_path_s_points(tmp_path):
    """--fps 30 over paths of a point every 0.1 s: one frame per point (10 a second), not 30 a second with two
    of every three repeating the one before (issue 75: half the frames of a --fps 15 study were repeats, and the
    recorded page weight counted them again)."""
    study = synthetic_study(tmp_path / "s", camera=True, fps=30, duration_s=3.9)  # 40 points: 39 steps of 0.1 s
    assert study.point_s == pytest.approx(0.1) and study.frame_fps == pytest.approx(10.0)
    for stim in study.stimuli.values():
        assert len(stim.view.frames) == len(stim.path)
    trial = assignment(study, 0)[1]
    assert served_trial(study, trial, 9)["view"]["fps"] == pytest.approx(10.0)  # the page's frame clock
    held = motion(study, trial, 1.0)["frames"]  # 1.0 s played, 0.2 s ahead: frames at 0.0, 0.1, ..., 1.2 s
    assert held == list(study.stimuli[trial.stimulus].view.frames[:13])


def _luminance(hex_colour: str) -> float:
    """WCAG 2 relative luminance of an sRGB colour "#RRGGBB"."""
    c = np.array([int(hex_colour[i:i + 2], 16) / 255 for i in (1, 3, 5)])
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return float(linear @ [0.2126, 0.7152, 0.0722])


def test_every_goal_colour_stands_out_from_the_canvas_and_has_its_own_initial():
    """WCAG's 3:1 for graphics against the page's white canvas (issue 75: the yellow goal was 1.32:1), and
    initials the page writes inside the goals that tell every goal apart without its colour."""
    for name, hex_colour in PALETTE:
        contrast = (1.0 + 0.05) / (_luminance(hex_colour) + 0.05)
        assert contrast >= 3.0, (name, round(contrast, 2))
    assert len({name[0] for name, _ in PALETTE}) == len(PALETTE)
