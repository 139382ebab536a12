"""Scenes that change during the motion: the event families, their rollouts, and what is measured
after the event (issue 65).

The trained models read two goals, so every family keeps two; a distractor "appears" by being put
down next to the target from out of play, and "vanishes" by being taken out of play:

* ``appear``: a scene clear at the start (eq. 3) whose distractor is put down where the scene
  becomes ambiguous;
* ``vanish``: an ambiguous scene whose distractor is taken away to where the scene is clear;
* ``move``: the target itself moves, to where the scene's ambiguity flips (either way).

The event happens once the robot has taken :data:`EVENT_FRACTION` of the steps a straight line to
the target takes. The scene before the event is labelled by eq. 3 at the start state, as every scene set's
is; the scene after it must be what its family says from where the event finds a robot that went straight
(:func:`event_point`), by eq. 3 and by the paper's ellipse alike (issue 76: labelled from the start, 15 of 40
Navigation and 17 of 40 Block Reach appear scenes were clear from where the robot was); the drawn scenes
this rejects are counted (``rejected_at_event``). "The style the new scene needs" is judged from where the
event found each robot, as SCDP's arbitration judges it at its next replan: legible where the rest of the way
is ambiguous, efficient where it is clear, by eq. 3 (``latency``) and by the ellipse (``latency_ellipse``).

Measures, per rollout, from the event on:

* ``latency``: replanning chunks from the event to the first chunk in the style the new scene needs (0:
  the first chunk planned after it); NaN for a planner without styles, or one that never switches;
  ``needs_legible``: whether that style is legible (each by eq. 3, and ``_ellipse`` by the ellipse);
* ``post_legible``: the share of the chunks after the event planned legible;
* ``observer``: the path-length observer's accuracy (β = 4) at 25, 50 and 75 % of the motion after
  the event, reading the new goal set, averaged;
* ``detour``: the length of the path after the event (cut at the target) over the straight distance
  from where the event found the robot to the target: 1 is the straight line, more is a detour;
* ``success``: at the target the episode ended with.

Not measured here: D̂, Ê and T of the post-event segment (their reference paths start at the task's
start, not mid-motion).
"""

from __future__ import annotations

import numpy as np

from scdp import ambiguity, observers
from scdp.data.scenes import EVALUATION, SceneEvent, sample_scene, scene_seed, stream_rng
from scdp.errors import ScdpError
from scdp.evaluation.rollout import Rollout, rollout
from scdp.evaluation.statistics import PairedDifference, difference_of
from scdp.keys import EVENT_KINDS
from scdp.scoring import cut_at_goal, observed_path
from scdp.tasks import Task

EVENT_FRACTION = 0.3  # of the straight line's steps, taken before the event
TRIES = 200  # draws of a replacement point before the scene itself is drawn again
LEGIBLE, EFFICIENT = "legible", "efficient"


def ambiguous(task: Task, goals: np.ndarray, target: int) -> bool:
    """Eq. 3 at the task's start: whether the straight path to ``goals[target]`` is ambiguous."""
    start = task.start_point
    return bool(ambiguity.probabilistic_flags(start[None], goals[None], np.array([target]), task.ambiguity)[0])


def _valid(task: Task, goals: np.ndarray, target: int) -> bool:
    try:
        task.validate_goals(goals, target)
    except ScdpError:
        return False
    return True


def _replaced(task: Task, rng, goals: np.ndarray, target: int, index: int, want_ambiguous: bool):
    """``goals`` with goal ``index`` redrawn from the task's box until the scene is valid and its label
    is ``want_ambiguous`` (None after :data:`TRIES` draws)."""
    for _ in range(TRIES):
        candidate = goals.copy()
        candidate[index] = task.sample_goals(rng, 2)[0]
        if _valid(task, candidate, target) and ambiguous(task, candidate, target) == want_ambiguous:
            return candidate
    return None


def event_step(task: Task, goals: np.ndarray, target: int) -> int:
    """The number of actions after which the event happens: :data:`EVENT_FRACTION` of a straight line's steps."""
    steps = np.linalg.norm(goals[target] - task.start_point) / task.step_size
    return max(1, int(round(EVENT_FRACTION * steps)))


def event_point(task: Task, goals: np.ndarray, target: int) -> np.ndarray:
    """Where the event finds a robot that went straight for the target: :data:`EVENT_FRACTION` of the way."""
    start = np.asarray(task.start_point, dtype=np.float64)
    return start + EVENT_FRACTION * (np.asarray(goals[target], dtype=np.float64) - start)


def ambiguous_from(task: Task, point, goals: np.ndarray, target: int) -> tuple[bool, bool]:
    """(eq. 3, the paper's ellipse): whether the rest of the way to ``goals[target]`` from ``point`` is ambiguous,
    as SCDP's arbitration judges it at a replan (``probabilistic`` and ``ellipse``)."""
    args = (np.asarray(point, dtype=np.float64)[None], np.asarray(goals)[None], np.array([target]), task.ambiguity)
    return bool(ambiguity.probabilistic_flags(*args)[0]), bool(ambiguity.ellipse_flags(*args)[0])


def event_scenes(task: Task, kind: str, n: int, seed: int, stream: str = EVALUATION) -> tuple[list[tuple], int]:
    """``n`` scenes of family ``kind`` from ``stream``: (goals, target, SceneEvent) each, the same for
    every method (each family its own sub-stream), and how many drawn scenes were rejected because the
    scene after the event, seen from where the event finds the robot (:func:`event_point`), is not what the
    family says by eq. 3 and by the ellipse alike (an appear scene ambiguous, a vanish scene clear, a move
    scene flipped from its start label)."""
    if kind not in EVENT_KINDS:
        raise ScdpError("--events", f"unknown event family {kind!r} (choose from {', '.join(EVENT_KINDS)})")
    rng = stream_rng(stream, seed, kind)
    out, rejected = [], 0
    while len(out) < n:
        goals, target = sample_scene(task, rng, 2)
        flag = ambiguous(task, goals, target)
        if kind == "move":
            after = _replaced(task, rng, goals, target, target, not flag)
            before = goals
        else:
            if flag != (kind == "appear"):  # appear: the after-scene is the ambiguous one drawn
                continue
            before = _replaced(task, rng, goals, target, 1 - target, not flag)
            after = goals
        if before is None or after is None:
            continue
        wanted = (kind == "appear") if kind != "move" else not flag
        if set(ambiguous_from(task, event_point(task, before, target), after, target)) != {wanted}:
            rejected += 1  # from where the event finds the robot, the new scene is not what its family says
            continue
        out.append((before, target, SceneEvent(kind, event_step(task, before, target), after, target)))
    return out, rejected


def event_measures(task: Task, run: Rollout) -> dict:
    """What one rollout did after its event (module docstring)."""
    ev = run.event
    if ev is None:  # the episode ended before the event
        return {"latency": float("nan"), "latency_ellipse": float("nan"), "needs_legible": float("nan"),
                "needs_legible_ellipse": float("nan"), "post_legible": float("nan"), "observer": float("nan"),
                "detour": float("nan"), "success": float(run.success), "event_reached": 0.0}
    eq3, ellipse = ambiguous_from(task, run.path[ev["step"]], ev["goals"], ev["target"])  # from where the robot is
    after = run.styles[ev["chunk"]:]
    styled = any(s in (LEGIBLE, EFFICIENT) for s in after)

    def latency(needs_legible: bool) -> float:
        hits = [k for k, s in enumerate(after) if s == (LEGIBLE if needs_legible else EFFICIENT)]
        return float(hits[0]) if hits and styled else float("nan")
    accuracy, detour = segment_measures(task, run.path[ev["step"]:], ev["goals"], ev["target"])
    return {"latency": latency(eq3), "latency_ellipse": latency(ellipse), "needs_legible": float(eq3),
            "needs_legible_ellipse": float(ellipse),
            "post_legible": float(np.mean([s == LEGIBLE for s in after])) if styled and after else float("nan"),
            "observer": accuracy, "detour": detour, "success": float(run.success), "event_reached": 1.0}


def segment_measures(task: Task, segment, goals, target: int) -> tuple[float, float]:
    """(observer accuracy, detour) of the part of a motion from some moment on, read as a motion of its own: the
    path-length observer's mean correctness along it (cut at the goal, :func:`scdp.scoring.observed_path`), and
    its length to the goal over the straight distance from its first point. NaN for fewer than 2 points."""
    segment = np.asarray(segment, dtype=np.float64)
    if len(segment) < 2:
        return float("nan"), float("nan")
    goals = np.asarray(goals, dtype=np.float64)
    path = observed_path(task, segment, goals, target)
    accuracy = float(np.mean(observers.correct_at(observers.posterior_along(path, goals, target), target)))
    cut = cut_at_goal(task, segment, goals, target)
    straight = float(np.linalg.norm(goals[target] - segment[0]))
    return accuracy, float(np.sum(np.linalg.norm(np.diff(cut, axis=0), axis=1)) / straight) if straight > 0 else float("nan")


COMPARED_MEASURES = ("observer", "detour", "success", "post_legible")  # compared between planners, paired by scene


def paired_difference(a: list[dict], b: list[dict], measure: str, seed: int, names=("a", "b")) -> PairedDifference:
    """``names[0] - names[1]`` on ``measure`` over the scenes both runs ``a`` and ``b`` (one row per scene,
    in the same order) define it on, paired by scene, with its 95 % scene-bootstrap interval. A detour is
    compared only where both runs succeeded (a failed run's uncut path is no detour); ``left_out`` counts
    the scenes left out for that."""
    pairs = [(i, x, y) for i, (x, y) in enumerate(zip(a, b)) if np.isfinite(x[measure]) and np.isfinite(y[measure])]
    kept = [(i, x, y) for i, x, y in pairs if measure != "detour" or (x["success"] == 1.0 and y["success"] == 1.0)]
    d = np.array([x[measure] - y[measure] for _, x, y in kept])
    if len(d) < 2:  # no interval from one scene
        return PairedDifference(*names, measure, len(d), len(d), float(d.mean()) if len(d) else float("nan"),
                                float("nan"), float("nan"), len(pairs) - len(kept))
    return difference_of(d, [i for i, _, _ in kept], *names, measure, seed=seed, left_out=len(pairs) - len(kept))


def _record(run: Rollout) -> dict:
    """What a rollout leaves in the results: its path (4 decimals), chunk styles and starts, and the event."""
    ev = run.event
    return {"path": np.round(np.asarray(run.path, dtype=np.float64), 4).tolist(), "styles": list(run.styles),
            "starts": list(run.starts), "goals": np.asarray(run.goals).tolist(), "target": run.target,
            "event": None if ev is None else {"kind": ev["kind"], "step": ev["step"], "chunk": ev["chunk"],
                                              "goals": np.asarray(ev["goals"]).tolist(), "target": ev["target"]}}


def evaluate_events(task: Task, planners: dict, kind: str, n: int, seed: int, *, stream: str = EVALUATION,
                    baseline: str | None = "dp", progress: bool = False) -> dict:
    """Every planner on the same ``n`` scenes of family ``kind`` with the same noise: per planner the
    measures' means and each scene's values, and each planner minus ``baseline``, paired by scene, with
    95 % scene-bootstrap intervals, for each measure both define on at least two scenes (a difference
    the baseline cannot have, as DP's share of legible chunks, is left out rather than written as NaN)."""
    scenes, rejected = event_scenes(task, kind, n, seed, stream)
    seeds = [scene_seed(seed, f"events_{kind}", i) for i in range(n)]
    per: dict = {}
    for label, planner in planners.items():
        runs = rollout(task, planner, [(g, t) for g, t, _ in scenes], seeds=seeds, events=[e for _, _, e in scenes],
                       progress=progress, desc=f"{kind}: {label}")
        rows = [{**event_measures(task, r), **_record(r)} for r in runs]
        per[label] = {"scenes": rows, "mean": {k: float(np.nanmean([r[k] for r in rows])) if any(
            np.isfinite(r[k]) for r in rows) else float("nan") for k in (*COMPARED_MEASURES, "latency", "event_reached")},
            "switched_within_2": float(np.mean([r["latency"] <= 2 for r in rows])),
            "switched_within_2_ellipse": float(np.mean([r["latency_ellipse"] <= 2 for r in rows])),
            "n_action_steps": int(planner.n_action_steps)}
    differences = []
    if baseline in per:
        for label in per:
            if label == baseline:
                continue
            for measure in COMPARED_MEASURES:
                d = paired_difference(per[label]["scenes"], per[baseline]["scenes"], measure, seed, (label, baseline))
                if d.scenes >= 2:  # undefined for one of the two (DP has no style to switch): nothing to state
                    differences.append(d.row())
    return {"family": kind, "task": task.name, "scenes": n, "seed": seed, "stream": stream,
            "event_fraction": EVENT_FRACTION, "rejected_at_event": rejected, "methods": per, "differences": differences}
