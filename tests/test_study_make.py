"""`scdp study make` on the tiny run's checkpoints, the design's draws, and a killed server.

The server's rules, the page and the analysis are tested on hand-made studies that need no training
(tests/test_study_server.py, test_study_page.py, test_study_analysis.py)."""

import os
import signal
import sqlite3
import time

import httpx
import numpy as np
import pytest
from test_study_page import _free_port, start_server

from helpers.studies import synthetic_study
from scdp.cli import main
from scdp.study import questions
from scdp.study.design import Trial, assignment, motion, served_trial
from scdp.study.make import read_study
from scdp.study.record import MAIN, PRACTICE

METHODS = ["dp", "scdp"]


def _make(tiny, out, task, extra=()):
    ckpt = tiny / task / "checkpoints"
    return main(["study", "make", "--task", task, "--checkpoints", str(ckpt), "--methods", *METHODS, "--scenes", "2",
                 "--attention", "1", "--duration-s", "1", "--fps", "5", "--completion-code", "DONE42",
                 "--out", str(out), *extra])


# the shared tiny run trains once per session; alone on a slow 2-core machine that is the bulk of this file
SLOW_FIXTURE = pytest.mark.timeout(1800)


@pytest.fixture(scope="module")
def nav_study(tiny_reproduction, tmp_path_factory):
    out = tmp_path_factory.mktemp("study") / "nav"
    assert _make(tiny_reproduction, out, "navigation") == 0
    return out


@SLOW_FIXTURE
def test_make_rolls_every_method_out_on_the_same_scenes(nav_study, tiny_reproduction, tmp_path, capsys):
    study = read_study(nav_study)
    stimuli = study.stimuli
    main_ids = study.ids(MAIN)
    assert len(main_ids) == len(METHODS) * 2 * 2 * 2  # methods x (2 ambiguous + 2 clear) x every one of 2 goals
    assert len(study.ids(PRACTICE)) == 1
    assert set(study.stimuli) == set(main_ids) | set(study.ids(PRACTICE))  # checks are main trials: no stimuli of their own
    for scene_set in ("ambiguous", "non_ambiguous"):
        for i in range(2):
            for target in (0, 1):
                same = [stimuli[f"main-{scene_set}-{i:03d}-{target}-{m}"] for m in METHODS]
                assert all(s.goals == same[0].goals and s.target == target for s in same)
                assert same[0].path[0] == same[1].path[0]  # the same start noise
            ends = [np.asarray(stimuli[f"main-{scene_set}-{i:03d}-{t}-{METHODS[0]}"].path[-1]) for t in (0, 1)]
            assert not np.allclose(ends[0], ends[1])  # a motion planned toward each goal (the tiny model's own)
    assert study.checkpoint_sha256 and study.config.completion_code == "DONE42"
    # the same command makes another study (a fresh secret salt): the public code and the seed cannot rebuild it ...
    assert len(study.config.salt) == 32
    assert _make(tiny_reproduction, tmp_path / "other", "navigation") == 0
    other = read_study(tmp_path / "other")
    assert other.config.salt != study.config.salt
    assert [s.goals for s in other.stimuli.values()] != [s.goals for s in stimuli.values()]
    # ... and study.json can: given the same salt, the same study
    assert _make(tiny_reproduction, tmp_path / "again", "navigation", ("--salt", study.config.salt)) == 0
    again = read_study(tmp_path / "again")
    assert again.stimuli == study.stimuli and again.scenes == study.scenes
    capsys.readouterr()
    assert _make(tiny_reproduction, nav_study, "navigation") == 2
    assert "already exists" in capsys.readouterr().err


@SLOW_FIXTURE
def test_block_reach_stimuli_are_frames_from_a_person_s_view(tiny_reproduction, tmp_path):
    assert _make(tiny_reproduction, tmp_path / "br", "block_reach") == 0
    study = read_study(tmp_path / "br")
    sid = study.ids(MAIN)[0]
    stim = study.stimuli[sid]
    view = stim.view
    # --fps 5: a frame every 0.2 s of this motion, played at the study's one speed (its own duration)
    seconds = (len(stim.path) - 1) * study.point_s
    assert view.kind == "camera" and len(view.frames) == int(np.floor(seconds * 5 + 1e-9)) + 1 > 2
    for name in view.frames:  # opaque names: nothing of the method, scene or goal
        assert len(name) == 28 and name.endswith(".jpg") and stim.method not in name and "-" not in name
        assert (tmp_path / "br" / "frames" / name).stat().st_size > 1000
    assert study.page_weight_mb > 0
    assert study.arm_drawn.startswith("Panda drawn with Franka's meshes")  # study.json says how the frames draw it
    px = np.array(view.path_px)
    assert len(px) == len(stim.path) and np.all((px >= 0) & (px < [view.width, view.height]))
    trial = Trial(1, sid, MAIN, True, [0, 1], [0, 1])
    flipped = served_trial(study, trial, 9)
    assert np.allclose(np.array(flipped["view"]["goals_px"])[:, 0], view.width - 1 - np.array(view.goals_px)[:, 0])
    assert np.allclose(np.array(flipped["goals"])[:, 1], -np.array(stim.goals)[:, 1]) and flipped["view"]["flip"]
    assert "path_px" not in flipped["view"] and "frames" not in flipped["view"]
    whole = motion(study, trial, seconds)  # the whole motion, once it has played whole
    assert np.allclose(np.array(whole["path_px"]), np.c_[view.width - 1 - px[:, 0], px[:, 1]])
    assert whole["frames"] == list(view.frames)
    # 0.1 s in, the page holds 0.2 s more (the lookahead): frames at t = 0 and 0.2 only
    assert motion(study, trial, 0.1)["frames"] == list(view.frames)[:2]


def test_the_latin_square_balances_methods_over_scenes_and_participants(tmp_path):
    study = synthetic_study(tmp_path / "s")
    seen = {}
    for number in range(40):
        trials = assignment(study, number)
        assert trials[0].kind == PRACTICE
        main_trials = trials[1:]  # the checks among them: they are main trials
        scenes = [t.stimulus.rsplit("-", 2)[0] for t in main_trials]
        assert len(scenes) == len(set(scenes)) == 4  # every scene once
        methods = [study.stimuli[t.stimulus].method for t in main_trials]
        assert all(methods.count(m) == 2 for m in METHODS)  # every method equally often
        for t in main_trials:
            seen[t.stimulus] = seen.get(t.stimulus, 0) + 1
        assert assignment(study, number) == trials  # rebuilt exactly from the arrival number
    assert set(seen) == set(study.ids(MAIN))  # every scene under every method toward every goal, for someone
    draws = [t for n in range(8) for t in assignment(study, n)]
    assert {t.mirror for t in draws} == {True, False} and len({tuple(t.colours) for t in draws}) > 2


def test_a_kill_9_between_two_trials_loses_no_confirmed_answer(tmp_path):
    synthetic_study(tmp_path / "s", duration_s=1.0)
    port = _free_port()
    url = f"http://127.0.0.1:{port}"
    proc = start_server(tmp_path / "s", port)
    bob = httpx.Client(base_url=url)  # holds bob's session cookie across the restart
    try:
        bob.post("/api/consent", json={"pid": "bob"})
        bob.post("/api/comprehension", json={"pid": "bob", "answers": list(questions.ANSWERS)})
        for trial in range(2):
            bob.post("/api/motion", json={"pid": "bob", "trial": trial})
            assert bob.post("/api/pick", json={"pid": "bob", "trial": trial, "goal": 1, "t": 0.0}).status_code == 200
            time.sleep(1.0)  # the motion plays (1 s) before the server takes the answer
            assert bob.post("/api/response", json={"pid": "bob", "trial": trial, "confidence": 2}).status_code == 200
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    with sqlite3.connect(tmp_path / "s" / "responses.sqlite") as db:  # read by SQLite itself, not through scdp
        assert [t for t, in db.execute("select trial from responses where pid='bob' order by trial")] == [0, 1]
    proc = start_server(tmp_path / "s", port)
    try:
        state = bob.post("/api/state", json={"pid": "bob"}).json()
        assert state["answered"] == 2 and state["trial"]["index"] == 2
    finally:
        proc.terminate()
        proc.wait()
