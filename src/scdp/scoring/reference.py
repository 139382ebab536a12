"""The reference set of a scene: ``n`` generator Bézier paths from the nominal start to g*.

The paths are drawn with the same control-point distribution as the demonstration generator
(:func:`scdp.data.bezier.demo_paths`), seeded, so the bounds of a scene are reproducible.
:class:`Bounds` holds the min-max of D and E over such a set
(:func:`scdp.scoring.score.reference_bounds` computes them).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from scdp.data.bezier import demo_paths
from scdp.metrics import resample
from scdp.tasks import Task

DEFAULT_REFERENCES = 100
FAMILY_PATHS, FAMILY_POINTS = 16, 64  # demonstrations per goal, points per demonstration (goal_families)
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


def reference_paths(task: Task, goals, target, n: int = DEFAULT_REFERENCES, seed: int = 0) -> list[np.ndarray]:
    """``n`` generator Bézier paths for this scene, from the nominal start to g*."""
    rng = np.random.default_rng(seed)
    start = task.start_point
    g_star = np.asarray(goals, dtype=np.float64)[target]
    return demo_paths(task, rng, start, g_star, n)


def goal_families(task: Task, goals, n: int = FAMILY_PATHS, points: int = FAMILY_POINTS, seed: int = 0) -> np.ndarray:
    """For every goal, ``n`` generator Bézier paths from the nominal start to it, resampled to
    ``points`` points: (K, n, points, d), what the demonstration observer expects
    (:func:`scdp.observers.demonstration_posterior`). Seeded: the same scene gives the same family."""
    goals = np.asarray(goals, dtype=np.float64)
    return np.stack([np.stack([resample(p, points) for p in reference_paths(task, goals, k, n, seed)])
                     for k in range(len(goals))])
