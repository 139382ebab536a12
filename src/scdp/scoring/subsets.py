"""Style subsets: the most legible and the most efficient demonstrations.

Scenes differ, so raw D and E are not comparable across demos. Each demo is scored
against its own scene's reference set (:mod:`scdp.scoring.reference`): ``d_hat`` ranks legibility,
``e_hat`` ranks efficiency (the paper's two subsets). The top ``fraction`` of demos by that score
forms the subset. ``transparency`` (T, eq. 7) is a third ranking, offered for the efficient
predictor: it keeps the demos that are efficient *and* detached where the goals are far apart.

Detachment is what the paper ranks the legible demos by, but a path can be detached without
telling an observer anything: an arm that lifts high stays far from both blocks. Two observer
rankings are offered for the legible predictor instead (:func:`observer_legibility`): Dragan's
legibility of the demo (what the path-length observer reads, early points weighing most), in task
space (``legibility``) or as the task's viewer sees the motion (``viewpoint_legibility``,
:func:`scdp.perception.as_seen`), each min-max normalised over the scene's reference paths as D̂
is, so that demos of hard and easy scenes compete on what their scene allows.

Each of those wins one reading of "legible" and loses the other, so two rankings ask for both
(:data:`JOINT_SCORES`, :func:`joint_ranking`), each on D̂ and task-space legibility:
``pareto`` keeps the first non-dominated fronts of the pair until the fraction is filled (no demo
is kept while one better on both is left out), the last front cut by ``rank_mean``; ``rank_mean``
ranks by the mean of the two normalised ranks (a demo middling on both beats one best on one and
worst on the other).
"""

from __future__ import annotations

import numpy as np

from scdp import ambiguity, metrics
from scdp.errors import ScdpError
from scdp.keys import LEGIBLE_SCORES, STYLES
from scdp.perception import as_seen
from scdp.scoring.reference import MIN_SPAN, reference_paths
from scdp.scoring.score import j_hat, normalised_scores, observed_path, reference_bounds
from scdp.tasks import Task

SCORES = ("d_hat", "e_hat", "transparency")  # columns of episode_scores
JOINT_SCORES = ("pareto", "rank_mean")  # D̂ and legibility together (joint_ranking)
OBSERVER_SCORES = tuple(s for s in LEGIBLE_SCORES if s not in SCORES + JOINT_SCORES)  # observer_legibility's rankings
PAPER_SCORE = {"legible": "d_hat", "efficient": "e_hat"}  # the paper's ranking for each style


def episode_scores(dataset, references: int = 100) -> np.ndarray:
    """(E, 3) array of per-scene normalised (d_hat, e_hat, transparency) for every episode."""
    task = dataset.task_object()
    out = np.empty((dataset.num_episodes, len(SCORES)))
    for i in range(dataset.num_episodes):
        ep = dataset.episode(i)
        bounds = reference_bounds(task, ep["goals"], ep["target"], n=references)
        d_hat, e_hat = normalised_scores(task, task.episode_path(ep), ep["goals"], ep["target"], bounds)
        out[i] = d_hat, e_hat, metrics.transparency(d_hat, e_hat, j_hat(task, ep["goals"], ep["target"]))
    return out


def path_legibility(task: Task, path, goals, target, viewpoint: bool = False) -> float:
    """Dragan's legibility of a path (:func:`scdp.metrics.legibility`, on the path cut at the goal and
    resampled as every score is), in task space or, with ``viewpoint``, as the task's viewer sees it."""
    goals = np.asarray(goals, dtype=np.float64)
    path = observed_path(task, path, goals, target)
    if viewpoint:
        path, goals = as_seen(task, path), as_seen(task, goals)
    return metrics.legibility(path, goals, target)


def observer_legibility(dataset, viewpoint: bool = False, references: int = 100) -> np.ndarray:
    """(E,) every episode's legibility (:func:`path_legibility`) min-max normalised over its scene's
    reference paths (0: as legible as the scene's least legible reference, 1: as the most)."""
    task = dataset.task_object()
    out = np.empty(dataset.num_episodes)
    for i in range(dataset.num_episodes):
        ep = dataset.episode(i)
        refs = [path_legibility(task, p, ep["goals"], ep["target"], viewpoint)
                for p in reference_paths(task, ep["goals"], ep["target"], references)]
        lo, hi = min(refs), max(refs)
        own = path_legibility(task, task.episode_path(ep), ep["goals"], ep["target"], viewpoint)
        out[i] = (own - lo) / max(hi - lo, MIN_SPAN)
    return out


def normalised_ranks(values: np.ndarray) -> np.ndarray:
    """(E,) each value's rank among ``values`` scaled to [0, 1] (1: the largest; ties share their mean rank)."""
    values = np.asarray(values, dtype=np.float64)
    if len(values) < 2:
        return np.ones(len(values))
    _, inverse, counts = np.unique(values, return_inverse=True, return_counts=True)
    mean_rank = np.cumsum(counts) - counts + (counts - 1) / 2  # 0-based, ties averaged
    return mean_rank[inverse] / (len(values) - 1)


def pareto_fronts(columns: np.ndarray) -> np.ndarray:
    """(E,) the non-dominated front of each row of ``columns`` (E, M), larger better: 0 for the rows
    no other row beats on every column (and strictly on one), 1 once those are removed, and so on."""
    columns = np.asarray(columns, dtype=np.float64)
    front = np.full(len(columns), -1)
    level = 0
    while (front < 0).any():
        left = np.flatnonzero(front < 0)
        sub = columns[left]
        beaten = ((sub[None, :, :] >= sub[:, None, :]).all(-1) & (sub[None, :, :] > sub[:, None, :]).any(-1)).any(1)
        front[left[~beaten]] = level
        level += 1
    return front


def joint_ranking(d_hat: np.ndarray, legibility: np.ndarray, score: str) -> np.ndarray:
    """(E,) a ranking (larger first) that asks for both detachment and legibility: ``rank_mean`` or
    ``pareto`` (:data:`JOINT_SCORES`, the module docstring)."""
    mean = (normalised_ranks(d_hat) + normalised_ranks(legibility)) / 2  # in [0, 1]
    if score == "rank_mean":
        return mean
    if score == "pareto":
        return -pareto_fronts(np.column_stack([d_hat, legibility])) + 0.5 * mean  # fronts first, rank_mean within one
    raise ScdpError("score", f"unknown joint ranking {score!r} (choose from {', '.join(JOINT_SCORES)})")


def top_fraction(scores: np.ndarray, fraction: float) -> np.ndarray:
    """Indices of the top ``fraction`` of ``scores`` (at least one), best first, ties in order."""
    k = max(1, int(round(fraction * len(scores))))
    return np.argsort(-np.asarray(scores), kind="stable")[:k]


def ambiguous_at_start(dataset) -> np.ndarray:
    """(E,) True where an episode's scene is ambiguous at its first point by eq. 3."""
    task = dataset.task_object()
    episodes = [dataset.episode(i) for i in range(dataset.num_episodes)]
    return ambiguity.probabilistic_flags(np.array([task.episode_path(ep)[0] for ep in episodes]),
                                         np.array([ep["goals"] for ep in episodes]),
                                         np.array([ep["target"] for ep in episodes]), task.ambiguity)


def style_subset(dataset, style: str = "legible", fraction: float = 0.2, *, references: int = 100,
                 score: str | None = None):
    """The top ``fraction`` of episodes for ``style``, as a new :class:`~scdp.data.dataset.DemoDataset`.

    ``score`` is the ranking (one of :data:`SCORES` or :data:`OBSERVER_SCORES`); by default the
    paper's: per-scene normalised detachment for "legible", efficiency for "efficient".
    """
    if style not in STYLES:
        raise ScdpError("style", f"unknown style {style!r} (choose from {', '.join(STYLES)})")
    if not 0.0 < fraction <= 1.0:
        raise ScdpError("fraction", f"must lie in (0, 1], got {fraction}")
    score = score or PAPER_SCORE[style]
    if score in JOINT_SCORES:
        ranking = joint_ranking(episode_scores(dataset, references)[:, 0], observer_legibility(dataset, False, references), score)
    elif score in OBSERVER_SCORES:
        ranking = observer_legibility(dataset, score == "viewpoint_legibility", references)
    elif score in SCORES:
        ranking = episode_scores(dataset, references)[:, SCORES.index(score)]
    else:
        raise ScdpError("score", f"unknown ranking {score!r} (choose from {', '.join(SCORES + OBSERVER_SCORES + JOINT_SCORES)})")
    sub = dataset.subset(top_fraction(ranking, fraction))
    sub.attrs.update(style=style, fraction=fraction, score=score)
    return sub


def subset_gaps(dataset, fraction: float = 0.2, *, references: int = 100) -> dict:
    """How far the style subsets themselves differ: mean d_hat of the top ``fraction`` legible
    demos minus that of the top ``fraction`` efficient demos, over all demos (``all``) and over
    the demos whose scene is ambiguous at the start by eq. 3 (``ambiguous``; the subsets are
    drawn from all demos, so this is their ambiguous members' means)."""
    scores = episode_scores(dataset, references)
    legible, efficient = top_fraction(scores[:, 0], fraction), top_fraction(scores[:, 1], fraction)
    ambiguous = ambiguous_at_start(dataset)
    out = {"all": float(scores[legible, 0].mean() - scores[efficient, 0].mean())}
    amb_l, amb_e = legible[ambiguous[legible]], efficient[ambiguous[efficient]]
    if len(amb_l) and len(amb_e):
        out["ambiguous"] = float(scores[amb_l, 0].mean() - scores[amb_e, 0].mean())
    return out
