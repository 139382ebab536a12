"""What a study shows and to whom: its settings, its trials, and each participant's assignment.

A study compares ``methods`` on the same scenes. A scene is a layout of goals; every method is rolled
out on every scene toward every one of its goals with the same noise (``scdp study make``), and a
participant sees each scene once, under one method and toward one goal. A Latin square over the methods
decides which method (participant ``k`` is on row ``k mod M``; scene ``s`` shows method ``(s + row) mod M``),
so each participant sees every method equally often; the target is an independent draw per participant and
scene (:func:`scene_targets`), so no run is the answer key of another: a scene's ending in one run says
nothing of its ending in the next, and a run holds no fixed number of nearer or farther targets to count
down. Scenes come in two sets, ambiguous and clear (eq. 3 of the paper, for every target of the scene
alike), ``scenes_per_set`` each, a multiple of M.

Rows are counted over participants who *consented*, never over IDs that only opened the link: a
new participant takes the row with the fewest finished or still-active participants (an active
one consented less than ``slot_timeout_min`` ago and has not finished; an abandoned slot is
released after it, as psiTurk does), ties to the lowest row (:meth:`scdp.study.store.Store.register`).

Each participant's run is: a practice trial, then the main trials in an order of their own. The
checks are main trials too, drawn per participant among those whose motion ends clearly at its target
(:func:`check_trials`, :func:`ends_clearly`): an attention check is graded at its end (the answer is
where the motion ends, which no other goal is near) and analysed like any other main trial; an
instructed-response check tells the participant, once the motion has ended, which goal to choose
whatever the robot did (never the one it went to), and only its picks before that note are data.
Nothing on the page tells a check from another trial before its end, and since every participant
sees every scene toward a target of its own, a scene that was a check in one run says nothing about the
next (results/study_checks.md bets on it).
Every trial has a random mirror image (y -> -y: left and right swap), a random assignment of
colours to goals, and its own order of the goals on the page (the served order, which is also the
buttons' order). The target's button is, within a participant's run, an independent uniform
draw per scene: neither the previous answers nor the practice's (whose answer the page reveals)
say anything about the next one, so no button pattern beats chance. (Balancing the buttons
*within* a run makes them learnable: results/study_checks.md.) The balance is across participants
instead, in blocks of M x K consent numbers: scene s puts its target on button
(u_bs + floor(number / M)) mod K, u_bs a secret uniform draw per block and scene, so a
Latin-square row's K participants in a block see each scene's target on every button once. The
analysis takes the button as a covariate (:mod:`scdp.study.covariates`). No position, side,
colour or index can be a cue. All of it is drawn from the study's seed mixed with its secret salt
(:attr:`~scdp.study.record.StudyConfig.stream_seed`) and the participant's consent number, so
:func:`assignment` rebuilds any participant's run exactly from study.json, and nobody can from the
public code.

What the page receives of a trial before the answer is :func:`served_trial` (the goals, their
colours, the start, never the path or the target) and then :func:`motion` (the path and frames up
to the moment the server's clock allows, never beyond). Every motion plays at one speed, as the robot
executed it (:attr:`~scdp.study.record.Study.point_s`), so its duration follows its length and the
robot's speed on screen says nothing the path does not; no count, length or duration of what is still
to come is ever sent.
"""

from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass, field

import numpy as np

from scdp.study.record import ANALYSED, ATTENTION, INSTRUCTED, MAIN, PRACTICE, SETS, Study

# goal colours a participant names goals by: distinct for the common colour-vision deficiencies (Okabe-Ito's
# vermillion, blue, bluish green and reddish purple, and a dark mustard), each at least 3:1 against the white
# canvas (WCAG contrast: 3.9, 5.2, 3.4, 3.1, 4.3; Okabe-Ito's orange, sky blue and yellow are 2.3, 2.3 and 1.3),
# with names of distinct initials, which the page writes inside each goal (tests/test_study_server.py)
PALETTE = (("red", "#D55E00"), ("blue", "#0072B2"), ("green", "#009E73"), ("pink", "#CC79A7"), ("mustard", "#8A7A00"))
SIMULATED_PREFIX = "SIM-"  # the IDs of simulated participants (scdp study simulate): never human data
API_STUDY_ID = "scdp-api"  # the platform study ID a simulated participant without a browser consents with
# Everything the page receives of a trial, field by field (tests/test_study_rules.py holds every answer to
# these): nothing in them may tell more than the motion shown so far.
TRIAL_FIELDS = ("index", "n_trials", "kind", "task", "point_s", "goals", "start", "colours", "view")
VIEW_FIELDS = ("kind", "width", "height", "flip", "goals_px", "poster", "fps")
MOTION_FIELDS = ("trial", "t", "done", "ended", "path", "path_px", "frames", "note")


@dataclass(frozen=True)
class Trial:
    """One trial of one participant: which stimulus, mirrored or not, the order the goals are served
    in (``order[j]`` is the stimulus's goal shown at position j) and each position's colour."""

    index: int  # 0 is the practice trial
    stimulus: str  # a key of study.json's "stimuli"
    kind: str  # PRACTICE, MAIN, ATTENTION or INSTRUCTED
    mirror: bool
    colours: list = field(default_factory=list)  # one palette index per served position
    order: list = field(default_factory=list)  # the stimulus's goal index at each served position
    instructed: int | None = None  # INSTRUCTED: the served position the participant is told to choose

    def to_dict(self) -> dict:
        return asdict(self)


def stimulus_id(kind: str, scene_set: str, index: int, target: int, method: str) -> str:
    return f"{kind}-{scene_set}-{index:03d}-{target}-{method}"


def _rng(seed: int, purpose: str, *numbers: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([int(seed), zlib.crc32(purpose.encode()), *map(int, numbers)]))


def scene_targets(study: Study, number: int) -> dict[tuple[str, int], int]:
    """The goal each scene moves to for the participant who consented ``number``-th: {(scene set, index): goal},
    an independent uniform draw per participant and scene. No run tells another's targets, nor how many nearer
    or farther ones it holds; across participants each goal is a scene's target equally often in expectation.
    (An exact balance, each of a Latin-square row's K participants in a block toward another goal, would make
    one run the complement of another: with two goals, every target the first did not have.)"""
    n = study.config.scenes_per_set
    draws = _rng(study.config.stream_seed, "study-targets", number).integers(study.goals, size=len(SETS) * n)
    return {(name, s): int(draws[j * n + s]) for j, name in enumerate(SETS) for s in range(n)}


def main_stimuli(study: Study, row: int, number: int) -> list[str]:
    """The main stimuli of the participant who consented ``number``-th, on Latin-square row ``row``: every
    scene once, scene s under method (s + row) mod M, toward the participant's goal (:func:`scene_targets`)."""
    methods, targets = study.config.methods, scene_targets(study, number)
    return [stimulus_id(MAIN, name, s, targets[name, s], methods[(s + row) % len(methods)])
            for name in SETS for s in range(study.config.scenes_per_set)]


def scene_key(study: Study, stimulus: str) -> tuple[str, int]:
    """The scene a stimulus shows: (scene set, scene index); every method's and every target's alike."""
    stim = study.stimuli[stimulus]
    return stim.scene_set, stim.scene_index


def target_buttons(study: Study, number: int) -> dict[tuple[str, int], int]:
    """Each scene's target button for the participant who consented ``number``-th: {scene_key: button}.

    Participants come in blocks of M x K consent numbers. A block draws a fresh uniform offset per
    scene; the participant adds one step per M consent numbers. Within a run the buttons are
    therefore independent uniform draws (a fresh block's offsets: no fixed mix of buttons to count
    down), and a row's K participants in a block put each scene's target on every button once."""
    methods, goals = len(study.config.methods), study.goals
    scenes = sorted({scene_key(study, sid) for sid in study.stimuli})
    offsets = _rng(study.config.stream_seed, "study-buttons", number // (methods * goals)).integers(goals, size=len(scenes))
    step = (number // methods) % goals
    return {scene: int((u + step) % goals) for scene, u in zip(scenes, offsets)}


def assignment(study: Study, number: int, row: int | None = None) -> list[Trial]:
    """The trials of the participant who consented ``number``-th (0-based) on Latin-square ``row``
    (default ``number mod M``): practice first, then the main trials shuffled, some of them checks
    (:func:`check_trials`), each with its mirror, goal order, colours and (instructed checks) the goal to choose."""
    rng = _rng(study.config.stream_seed, "study-participant", number)
    row = number % len(study.config.methods) if row is None else row
    main = main_stimuli(study, row, number)
    order = [main[i] for i in rng.permutation(len(main))]
    kinds = check_trials(study, order, rng)
    practice = study.ids(PRACTICE)
    buttons = target_buttons(study, number)
    trials = []
    for i, stim in enumerate(practice + order):
        stimulus, position = study.stimuli[stim], buttons[scene_key(study, stim)]
        kind = PRACTICE if i < len(practice) else kinds[i - len(practice)]
        others = [int(g) for g in rng.permutation(len(stimulus.goals)) if g != stimulus.target]
        served = others[:position] + [int(stimulus.target)] + others[position:]
        told = None
        if kind == INSTRUCTED:  # any button but the one the motion goes to
            told = int(rng.choice([p for p in range(len(served)) if p != position]))
        trials.append(Trial(index=i, stimulus=stim, kind=kind, mirror=bool(rng.integers(2)),
                            colours=[int(c) for c in rng.permutation(len(PALETTE))[:len(served)]], order=served,
                            instructed=told))
    return trials


def ends_clearly(stimulus, radius: float) -> bool:
    """Whether where ``stimulus``'s motion ends has one right answer: within ``radius`` (the task's success
    radius) of its target, and nearer the target than any other goal by at least ``radius`` (so outside
    every other goal's radius too). A motion can reach its target and still end nearer another goal."""
    goals = np.asarray(stimulus.goals, dtype=np.float64)
    d = np.linalg.norm(goals - np.asarray(stimulus.path[-1], dtype=np.float64), axis=1)
    others = np.delete(d, stimulus.target)
    return bool(d[stimulus.target] <= radius and np.all(others >= d[stimulus.target] + radius))


def check_trials(study: Study, order: list[str], rng: np.random.Generator) -> list[str]:
    """The kind of each of a participant's main trials (``order``): ``attention`` and ``instructed`` of
    them, drawn uniformly among those whose motion ends clearly at its target (:func:`ends_clearly`: where
    it ends is the target, and only the target), are checks; the rest MAIN. A check is any main trial, the
    first included."""
    kinds = [MAIN] * len(order)
    eligible = [i for i, sid in enumerate(order) if ends_clearly(study.stimuli[sid], study.success_radius)]
    wanted = [ATTENTION] * study.config.attention + [INSTRUCTED] * study.config.instructed
    for i, kind in zip(rng.permutation(eligible), wanted):
        kinds[int(i)] = kind
    return kinds


def rating_items(study: Study, trials: list[Trial], number: int) -> list[int]:
    """The trials a participant rates at the end, one main trial per method they saw, in a random
    order (drawn from their own stream): trial indices; the page never learns the method."""
    rng = _rng(study.config.stream_seed, "study-ratings", number)
    items = []
    for method in study.config.methods:
        seen = [t.index for t in trials if t.kind in ANALYSED and study.stimuli[t.stimulus].method == method]
        if seen:
            items.append(int(rng.choice(seen)))
    return [items[i] for i in rng.permutation(len(items))]


def mirrored(points, mirror: bool) -> list:
    """Task-space points with y negated when ``mirror`` (left and right swap; x and z stay)."""
    p = np.asarray(points, dtype=np.float64).copy()
    if mirror:
        p[..., 1] = -p[..., 1]
    return p.tolist()


def served_trial(study: Study, trial: Trial, n_trials: int) -> dict:
    """What the page gets of a trial before it plays (:data:`TRIAL_FIELDS`): the goals in the trial's
    order, mirrored and coloured, where the robot starts (for a camera view, the first frame), and the
    playback rate every motion of the study shares; never the rest of the path, its length, its
    duration, its frames or the target."""
    stim = study.stimuli[trial.stimulus]
    goals = np.asarray(stim.goals)[trial.order]
    view = {"kind": stim.view.kind}
    if stim.view.kind == "camera":
        width = stim.view.width
        px = np.asarray(stim.view.goals_px, dtype=np.float64)[trial.order]
        if trial.mirror:
            px[:, 0] = width - 1 - px[:, 0]
        view.update(width=width, height=stim.view.height, flip=trial.mirror, goals_px=px.tolist(),
                    poster=stim.view.frames[0], fps=study.frame_fps)  # the scene at t = 0, before Start
    kind = PRACTICE if trial.kind == PRACTICE else "trial"  # a check looks like any other trial
    return {"index": trial.index, "n_trials": n_trials, "kind": kind, "task": study.task, "point_s": study.point_s,
            "goals": mirrored(goals, trial.mirror), "start": mirrored(stim.path[0], trial.mirror),
            "colours": [{"name": PALETTE[c][0], "hex": PALETTE[c][1]} for c in trial.colours], "view": view}


def motion(study: Study, trial: Trial, elapsed_s: float) -> dict:
    """The part of a trial's motion the page may hold ``elapsed_s`` seconds after it started
    (:data:`MOTION_FIELDS`): the path's points up to ``elapsed_s`` + the study's ``lookahead_s`` (one beyond, to
    interpolate), and for camera views the pixel path and the frames (by their opaque names) up to
    there; ``done`` once nothing is left to send, and ``ended`` once the server's clock has passed the
    motion's end, both alike for every kind of trial (an instructed check's note comes with ``ended``).
    Nothing about the part not yet shown: no point count, length or duration."""
    stim = study.stimuli[trial.stimulus]
    n, horizon = len(stim.path), elapsed_s + study.config.lookahead_s
    keep = min(n, int(np.ceil(horizon / study.point_s - 1e-9)) + 1)
    out = {"t": float(elapsed_s), "done": keep == n, "path": mirrored(stim.path[:keep], trial.mirror)}
    if stim.view.kind == "camera":
        view = stim.view
        px = np.asarray(view.path_px[:keep], dtype=np.float64).reshape(-1, 2)
        if trial.mirror:
            px[:, 0] = view.width - 1 - px[:, 0]
        frames = list(view.frames)
        shown = len(frames) if keep == n else min(len(frames), int(np.floor(horizon * study.frame_fps + 1e-9)) + 1)
        out.update(path_px=px.tolist(), frames=frames[:shown])
    if elapsed_s >= study.motion_s(trial.stimulus) - 1e-9:  # the server's clock passed the end: so for every trial
        out["ended"] = True
        if trial.instructed is not None:  # the instruction, only now (the picks before it are data)
            colour = PALETTE[trial.colours[trial.instructed]][0]
            out["note"] = f"Attention: whatever the robot did, choose the {colour} goal for this trial."
    return out
