"""Scoring one path in one scene, under the conventions of :mod:`scdp.scoring`.

:func:`raw_scores` gives D and E of a path cut at the goal (:func:`cut_at_goal`);
:func:`reference_bounds` their min-max over the scene's reference set
(:mod:`scdp.scoring.reference`); :func:`normalised_scores` D̂ and Ê against those bounds;
:func:`j_hat` the normalised goal separation; :func:`score_path` every metric at once.
"""

from __future__ import annotations

import numpy as np

from scdp import metrics
from scdp.errors import ScdpError
from scdp.scoring.reference import DEFAULT_REFERENCES, MIN_SPAN, Bounds, reference_paths
from scdp.tasks import Task

RESAMPLE_POINTS = 200


def cut_at_goal(task: Task, path, goals, target) -> np.ndarray:
    """Cut a task-space path at its first point inside the success radius (a convention of :mod:`scdp.scoring`)."""
    return metrics.truncate_at_goal(path, np.asarray(goals)[target], task.success_radius)


def observed_path(task: Task, path, goals, target) -> np.ndarray:
    """The path an observer is scored on (D, legibility, :mod:`scdp.observers`): cut at the goal and
    resampled to :data:`RESAMPLE_POINTS` points, linearly in time."""
    return metrics.resample(cut_at_goal(task, path, goals, target), RESAMPLE_POINTS)


def raw_scores(task: Task, path, goals, target) -> tuple[float, float]:
    """(D, E) of a path under the conventions of :mod:`scdp.scoring`. D uses the nearest distractor."""
    goals = np.asarray(goals, dtype=np.float64)
    cut = cut_at_goal(task, path, goals, target)
    negatives = np.delete(goals, target, axis=0)
    return metrics.detachment(metrics.resample(cut, RESAMPLE_POINTS), negatives), metrics.efficiency(cut)


def raw_scores_many(task: Task, paths, goals, target) -> np.ndarray:
    """:func:`raw_scores` of each of ``paths`` in one scene, (n, 2): D of all of them at once, each
    value the same as the path's own."""
    goals = np.asarray(goals, dtype=np.float64)
    cuts = [cut_at_goal(task, p, goals, target) for p in paths]
    negatives = np.delete(goals, target, axis=0)  # (K - 1, d)
    traj = np.stack([metrics.resample(c, RESAMPLE_POINTS) for c in cuts])  # (n, T, d)
    t = np.arange(1, RESAMPLE_POINTS + 1)
    dist = np.linalg.norm(traj[:, None, :, :] - negatives[None, :, None, :], axis=-1)  # (n, K - 1, T)
    detachment = np.min((dist / t).sum(axis=2), axis=1)
    return np.column_stack([detachment, [metrics.efficiency(c) for c in cuts]])


def reference_bounds(task: Task, goals, target, n: int = DEFAULT_REFERENCES, seed: int = 0) -> Bounds:
    """Min-max bounds of D and E over the scene's reference set.

    Raises :class:`ScdpError` (field ``goals``) when a span is below :data:`MIN_SPAN`: every
    reference path then scores alike, and a normalised score would divide by ~0.
    """
    scores = raw_scores_many(task, reference_paths(task, goals, target, n, seed), goals, target)
    bounds = Bounds(float(scores[:, 0].min()), float(scores[:, 0].max()), float(scores[:, 1].min()), float(scores[:, 1].max()))
    for name, lo, hi in (("detachment", bounds.d_min, bounds.d_max), ("efficiency", bounds.e_min, bounds.e_max)):
        if not hi - lo >= MIN_SPAN:
            raise ScdpError("goals", f"the scene's reference paths all have the same {name} ({lo:.3g} to {hi:.3g}), "
                                     "so its normalisation bounds collapse; move the goals apart or away from the start")
    return bounds


def j_hat(task: Task, goals, target) -> float:
    """Distance from g* to its nearest distractor, normalised over the task's range."""
    j = metrics.goal_separation(goals, target)
    lo, hi = task.goal_distance_range()
    return float(np.clip(metrics.min_max(j, lo, hi), 0.0, 1.0))


def normalised_scores(task: Task, path, goals, target, bounds: Bounds) -> tuple[float, float]:
    """(d_hat, e_hat): D and E of a path min-max normalised by its scene's reference bounds."""
    D, E = raw_scores(task, path, goals, target)
    return float(metrics.min_max(D, bounds.d_min, bounds.d_max)), float(metrics.min_max(E, bounds.e_min, bounds.e_max))


def score_path(task: Task, path, goals, target, bounds: Bounds | None = None, *, beta: float = metrics.DEFAULT_BETA,
               u: float = 2.5, x0: float = 0.5) -> dict:
    """Every metric of one path in one scene: D, E, d_hat, e_hat, j_hat, T, legibility, success."""
    goals = np.asarray(goals, dtype=np.float64)
    bounds = bounds or reference_bounds(task, goals, target)
    D, E = raw_scores(task, path, goals, target)
    d_hat, e_hat = normalised_scores(task, path, goals, target, bounds)
    jh = j_hat(task, goals, target)
    cut = observed_path(task, path, goals, target)
    return {
        "detachment": D,
        "efficiency": E,
        "d_hat": d_hat,
        "e_hat": e_hat,
        "j_hat": jh,
        "transparency": float(metrics.transparency(d_hat, e_hat, jh, u, x0)),
        "legibility": metrics.legibility(cut, goals, target, beta=beta),
        "beta": beta,
        "success": metrics.success(path, goals[target], task.success_radius),
    }
