"""A study folder built without any trained model: hand-drawn paths, for the study's server, page and
analysis tests (seconds, on any machine), and a participant driven through its API on a clock the
test moves. ``scdp study make`` itself is tested on the tiny run."""

import hashlib
import json

import cv2
import numpy as np

from scdp.study import questions
from scdp.study.design import assignment, rating_items, stimulus_id
from scdp.study.make import frame_points
from scdp.study.record import FORMAT, MAIN, PRACTICE, SETS, Screening, Study, StudyConfig, frame_rate, point_seconds

GOALS = ([1.6, 0.7], [1.6, -0.7])


def _path(goals, target, bend: float, points: int = 40) -> list:
    """From the origin toward ``goals[target]``, bowed sideways away from the other goal by ``bend``,
    stopping short of the goal (as a stimulus stops at the success radius)."""
    goal = np.asarray(goals[target], dtype=np.float64)
    s = np.linspace(0.0, 0.95, points)[:, None]
    side = np.sign(goal[1]) * bend * np.sin(np.pi * s)
    return np.round(s * goal + np.c_[np.zeros_like(side), side], 4).tolist()


def _frames(folder, count: int, seed: int) -> list:
    names = []
    for i in range(count):
        image = np.full((36, 48, 3), (40 + 7 * i + seed) % 255, np.uint8)
        data = cv2.imencode(".jpg", image)[1].tobytes()
        name = hashlib.sha256(data).hexdigest()[:24] + ".jpg"
        (folder / name).write_bytes(data)
        names.append(name)
    return names


def synthetic_study(folder, *, camera: bool = False, points: dict | None = None, bends: tuple | None = None,
                    **config) -> Study:
    """Write a study folder (``study.json``, and frames when ``camera``) of two methods, 2 + 2 scenes,
    a practice, one attention check and one instructed-response check per participant (main trials
    drawn per participant: scdp.study.design.check_trials); dp's paths head straight for
    the target, scdp's bow away from the other goal. ``points`` gives a method's paths another number
    of points than 40 (another length, so another duration at the study's one speed); ``bends`` each method's
    sideways bow (default 0 and 0.5; a negative one heads for the other goal first); ``config``
    overrides :class:`StudyConfig`'s fields."""
    settings = {"methods": ("dp", "scdp"), "scenes_per_set": 2, "attention": 1, "instructed": 1, "duration_s": 1.0,
                "completion_code": "DONE42", "declined_code": "NOPE42", "screened_code": "SCRN42", "fps": 10, **config}
    if isinstance(settings.get("screening"), dict):
        settings["screening"] = Screening(**settings["screening"])
    cfg = StudyConfig(**settings)
    points = {m: (points or {}).get(m, 40) for m in cfg.methods}
    point_s = point_seconds(cfg.duration_s, [points[m] for m in cfg.methods])  # equal main counts per method
    folder.mkdir(parents=True, exist_ok=True)
    frames = folder / "frames"
    if camera:
        frames.mkdir()
    stimuli = {}

    def add(kind, scene_set, i, method, target, bend):
        goals = [list(g) for g in GOALS]
        path = _path(goals, target, bend, points[method])
        view = {"kind": "top"}
        if camera:
            px = (np.asarray(path) * [100, 100] + [240, 180]).round(1).tolist()
            count = len(frame_points(len(path), point_s, frame_rate(cfg.fps, point_s)))
            view = {"kind": "camera", "width": 480, "height": 360, "frames": _frames(frames, count, len(stimuli)),
                    "path_px": px, "goals_px": (np.asarray(goals) * [100, 100] + [240, 180]).tolist()}
        stimuli[stimulus_id(kind, scene_set, i, target, method)] = {
            "kind": kind, "method": method, "scene_set": scene_set, "scene_index": i, "goals": goals,
            "target": target, "path": path, "success": True, "styles": [], "view": view}

    for method, bend in zip(cfg.methods, bends or (0.0, 0.5)):
        for scene_set in SETS:
            for i in range(cfg.scenes_per_set):
                for target in range(len(GOALS)):  # every scene toward every goal, as scdp study make writes it
                    add(MAIN, scene_set, i, method, target=target, bend=bend)
    add(PRACTICE, "practice", 0, cfg.methods[0], target=0, bend=0.0)
    study = {"format": FORMAT, "task": "navigation", "goals": 2, "success_radius": 0.15, "config": cfg.to_dict(), "stimuli": stimuli,
             "command": "synthetic", "page_weight_mb": 0.0}
    (folder / "study.json").write_text(json.dumps(study))
    return Study.from_dict(study)


class Clock:
    def __init__(self):
        self.now = 1_000_000.0

    def __call__(self):
        return self.now


def enrol(client, pid, **platform):
    """Consent and pass the comprehension check (or, in a browser that did, resume): the state."""
    state = client.post("/api/consent", json={"pid": pid, **platform}).json()
    if state["screen"] != "instructions":
        return state
    return client.post("/api/comprehension", json={"pid": pid, "answers": list(questions.ANSWERS)}).json()


def take_trial(client, clock, pid, trial, *, position=0, at=0.3, lag=0.0, confirm_after=0.5, confidence=3,
               duration=1.0):
    """Start the motion, pick ``position`` at ``at`` seconds (the page showing ``at - lag``), wait for
    the end (a motion of ``duration`` seconds: the synthetic study's 40-point paths at its default 1 s)
    and ``confirm_after`` more seconds, confirm with ``confidence``: the /api/response answer."""
    assert client.post("/api/motion", json={"pid": pid, "trial": trial}).status_code == 200
    clock.now += at
    r = client.post("/api/pick", json={"pid": pid, "trial": trial, "goal": position, "t": max(0.0, at - lag)})
    assert r.status_code == 200, r.text
    clock.now += max(0.0, duration - at) + confirm_after
    return client.post("/api/response", json={"pid": pid, "trial": trial, "confidence": confidence})


def trials_of(store, study, pid):
    person = store.participant(pid)
    return assignment(study, person["number"], person["row"])


def rate_all(client, store, study, pid, legible=5, predictable=4):
    """Give the end-of-study ratings: the final state."""
    trials, number = trials_of(store, study, pid), store.participant(pid)["number"]
    given = [{"item": i, "legible": legible, "predictable": predictable} for i in rating_items(study, trials, number)]
    return client.post("/api/ratings", json={"pid": pid, "ratings": given})


def take_study(client, store, clock, pid, study, *, correct=True, rate=True, **kw):
    """A participant through every trial, choosing the target, or the instructed goal (or neither),
    then (``rate``) the ratings; the final state."""
    state = enrol(client, pid)
    while state["screen"] == "trial":
        index = state["trial"]["index"]
        spec = trials_of(store, study, pid)[index]
        target = spec.order.index(study.stimuli[spec.stimulus].target)
        right = spec.instructed if spec.instructed is not None else target
        position = right if correct else next(p for p in range(len(spec.order)) if p != right)
        r = take_trial(client, clock, pid, index, position=position, **kw)
        assert r.status_code == 200, r.text
        state = r.json()
    if rate and state["screen"] == "ratings":
        r = rate_all(client, store, study, pid)
        assert r.status_code == 200, r.text
        state = r.json()
    return state
