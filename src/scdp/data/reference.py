"""Per-scene normalisation: reference demonstrations and normalised scores.

The paper min-max normalises D and E "with respect to the training dataset". Since every
scene differs, we normalise each scene against a *reference set* generated for that scene
on demand: ``n`` Bézier paths from the task's nominal start to g*, drawn with the same
control-point distribution as the demonstration generator (seeded, so the bounds of a
scene are reproducible).

Reference paths are the generator's task-space Bézier curves, not simulated executions,
which makes hundreds of scenes cheap. ``benchmarks/reference_fidelity.py`` shows that D and
E of these curves match those of the executed demonstrations closely.

Conventions (as the authors did, plus REFERENCE §6):

* Every path — reference or rollout — is first cut at its first point inside the success
  radius, so a rollout that stops on entering the radius is compared like with like.
* D is computed on the cut path resampled to 200 points linearly in time; E on the cut
  path as it is. Dragan legibility uses the same 200-point path.
* ``d_hat = (D - d_min) / (d_max - d_min)`` and likewise E; not clipped.
* ``j_hat`` is the goal distance min-max normalised over the task's range
  ``[min_goal_separation, diagonal of the goal sampling box]``, clipped to [0, 1].
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from scdp import metrics
from scdp.data.bezier import demo_path
from scdp.errors import ScdpError

RESAMPLE_POINTS = 200
DEFAULT_REFERENCES = 100
MIN_SPAN = 1e-6  # smallest accepted max - min of D or E over a scene's reference set


@dataclass(frozen=True)
class Bounds:
    """Min-max bounds of detachment and efficiency over a scene's reference set."""

    d_min: float
    d_max: float
    e_min: float
    e_max: float

    def to_dict(self) -> dict:
        return asdict(self)


def cut_at_goal(task, path, goals, target) -> np.ndarray:
    """Cut a task-space path at its first point inside the success radius (the shared convention above)."""
    return metrics.truncate_at_goal(path, np.asarray(goals)[target], task.success_radius)


def raw_scores(task, path, goals, target) -> tuple[float, float]:
    """(D, E) of a path under the conventions above. D uses the nearest distractor."""
    goals = np.asarray(goals, dtype=np.float64)
    cut = cut_at_goal(task, path, goals, target)
    negatives = np.delete(goals, target, axis=0)
    return metrics.detachment(metrics.resample(cut, RESAMPLE_POINTS), negatives), metrics.efficiency(cut)


def reference_paths(task, goals, target, n: int = DEFAULT_REFERENCES, seed: int = 0) -> list[np.ndarray]:
    """``n`` generator Bézier paths for this scene, from the nominal start to g*."""
    rng = np.random.default_rng(seed)
    start = task.start_point
    g_star = np.asarray(goals, dtype=np.float64)[target]
    return [demo_path(task, rng, start, g_star)[0] for _ in range(n)]


def reference_bounds(task, goals, target, n: int = DEFAULT_REFERENCES, seed: int = 0) -> Bounds:
    """Min-max bounds of D and E over the scene's reference set.

    Raises :class:`ScdpError` (field ``goals``) when a span is below :data:`MIN_SPAN`: every
    reference path then scores alike, and a normalised score would divide by ~0.
    """
    scores = np.array([raw_scores(task, p, goals, target) for p in reference_paths(task, goals, target, n, seed)])
    bounds = Bounds(float(scores[:, 0].min()), float(scores[:, 0].max()), float(scores[:, 1].min()), float(scores[:, 1].max()))
    for name, lo, hi in (("detachment", bounds.d_min, bounds.d_max), ("efficiency", bounds.e_min, bounds.e_max)):
        if not hi - lo >= MIN_SPAN:
            raise ScdpError("goals", f"the scene's reference paths all have the same {name} ({lo:.3g} to {hi:.3g}), "
                                     "so its normalisation bounds collapse; move the goals apart or away from the start")
    return bounds


def j_hat(task, goals, target) -> float:
    """Distance from g* to its nearest distractor, normalised over the task's range."""
    goals = np.asarray(goals, dtype=np.float64)
    j = np.min(np.linalg.norm(np.delete(goals, target, axis=0) - goals[target], axis=1))
    lo, hi = task.goal_distance_range()
    return float(np.clip(metrics.min_max(j, lo, hi), 0.0, 1.0))


def normalised_scores(task, path, goals, target, bounds: Bounds) -> tuple[float, float]:
    """(d_hat, e_hat): D and E of a path min-max normalised by its scene's reference bounds."""
    D, E = raw_scores(task, path, goals, target)
    return float(metrics.min_max(D, bounds.d_min, bounds.d_max)), float(metrics.min_max(E, bounds.e_min, bounds.e_max))


def score_path(task, path, goals, target, bounds: Bounds | None = None, *, beta: float = metrics.DEFAULT_BETA,
               u: float = 2.5, x0: float = 0.5) -> dict:
    """Every metric of one path in one scene: D, E, d_hat, e_hat, j_hat, T, legibility, success."""
    goals = np.asarray(goals, dtype=np.float64)
    bounds = bounds or reference_bounds(task, goals, target)
    D, E = raw_scores(task, path, goals, target)
    d_hat, e_hat = normalised_scores(task, path, goals, target, bounds)
    jh = j_hat(task, goals, target)
    cut = metrics.resample(cut_at_goal(task, path, goals, target), RESAMPLE_POINTS)
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
