"""Style windows by the path that remains: what a predictor must do once a motion is under way.

The style subsets (:mod:`scdp.scoring.subsets`) rank whole demonstrations, so a predictor learns
the style of a path from its start. A style chosen part-way needs another label: from the state a
window starts at, is the rest of its path legible (or efficient) *for what is left*? Each step of
each demo is scored by the path from it to the goal against the straight line from the same
point, and the top ``fraction`` of the steps is kept within each tenth of the motion, so that
late windows compete with late windows and every part of a motion is taught.

    legible    legibility of the rest minus that of the straight rest (Dragan's path-length
               observer, who has watched since the demo's start; eq. 2 weights over the rest)
    efficient  length of the straight rest over that of the rest (1: already straight)

Both paths are cut at the goal and resampled as every score is (:func:`~scdp.scoring.score.observed_path`).
Arrays are indexed by every step of every episode in order, as :class:`scdp.data.windows.WindowData`
orders its windows.
"""

from __future__ import annotations

import numpy as np

from scdp import metrics
from scdp.errors import ScdpError
from scdp.keys import STYLES
from scdp.scoring.score import observed_path
from scdp.tasks import Task

PROGRESS_BINS = 10  # steps compete for a style window within each tenth of their motion


def rest_score(task: Task, path: np.ndarray, k: int, goals, target: int, style: str) -> float:
    """How the rest of ``path`` (T, d) from its point ``k`` scores for ``style`` against the straight rest."""
    goal = np.asarray(goals, dtype=np.float64)[target]
    steps = max(int(np.ceil(np.linalg.norm(goal - path[k]) / task.step_size)), 1)
    rest, straight = path[k:], np.linspace(path[k], goal, steps + 1)  # the straight rest at the demos' step
    rest, straight = observed_path(task, rest, goals, target), observed_path(task, straight, goals, target)
    if metrics.path_length(straight) < 1e-9:  # inside the success radius already: nothing left to shape
        return 1.0 if style == "efficient" else 0.0
    if style == "efficient":
        return metrics.path_length(straight) / max(metrics.path_length(rest), 1e-9)
    return (metrics.legibility(rest, goals, target, start=path[0])
            - metrics.legibility(straight, goals, target, start=path[0]))


def rest_scores(dataset, style: str) -> np.ndarray:
    """(N,) :func:`rest_score` at every recorded step of every episode of ``dataset`` (its state's point)."""
    if style not in STYLES:
        raise ScdpError("style", f"unknown style {style!r} (choose from {', '.join(STYLES)})")
    task = dataset.task_object()
    out = []
    for i in range(dataset.num_episodes):
        ep = dataset.episode(i)
        path = task.episode_path(ep)
        out += [rest_score(task, path, k, ep["goals"], ep["target"], style) for k in range(len(ep["state"]))]
    return np.asarray(out)


def top_by_progress(scores: np.ndarray, progress: np.ndarray, fraction: float, bins: int = PROGRESS_BINS) -> np.ndarray:
    """(N,) bool: the top ``fraction`` of ``scores`` (at least one) within each of ``bins`` equal
    bins of ``progress`` in [0, 1)."""
    if not 0.0 < fraction <= 1.0:
        raise ScdpError("fraction", f"must lie in (0, 1], got {fraction}")
    scores, progress = np.asarray(scores, dtype=np.float64), np.asarray(progress, dtype=np.float64)
    keep = np.zeros(len(scores), dtype=bool)
    which = np.minimum((progress * bins).astype(int), bins - 1)
    for b in np.unique(which):
        members = np.flatnonzero(which == b)
        k = max(1, int(round(fraction * len(members))))
        keep[members[np.argsort(-scores[members], kind="stable")[:k]]] = True
    return keep
