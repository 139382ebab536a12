"""Does a faster planner keep the styles? A candidate planner against the full one, on the same scenes.

Both plan every scene twice, once forced legible (``scdp_legible``) and once forced efficient
(``scdp_efficient``), from the same start states. Each measure is the candidate's minus the full
planner's, paired by scene, with its 95 % scene-bootstrap interval (:class:`PairedDifference`):

* ``path_distance``: the mean distance, in task-space metres, between the candidate's path and the
  full planner's path of the same style on the same scene, both resampled to :data:`RESAMPLED_POINTS`
  points by arc length (every scene, both styles). A second run of the full planner with its noise
  redrawn gives the floor that sampler noise alone reaches;
* ``d_hat_gap``: the forced-style D̂ gap (legible − efficient), candidate minus full, in ambiguous scenes;
* ``observer_gap``: the path-length observer right at half the motion (legible − efficient), candidate
  minus full, in ambiguous scenes.

:func:`keeps_style` is the rule: the candidate keeps at least :data:`MIN_GAP_SHARE` of the full planner's
forced-style D̂ gap, and the observer-gap difference's lower 95 % bound is above −:data:`OBSERVER_MARGIN`
(round 1's observer margin of the real-time gate). A planner with its films removed has no gap: it fails.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from scdp.evaluation.adaptivity import MIDWAY
from scdp.evaluation.noninferiority import MIN_GAP_SHARE
from scdp.evaluation.observation import PATH_LENGTH, Belief, Measured
from scdp.evaluation.records import TrajectoryRecord, record_value
from scdp.evaluation.statistics import PairedDifference, difference_of, matched
from scdp.keys import AMBIGUOUS

LEGIBLE, EFFICIENT = "scdp_legible", "scdp_efficient"
RESAMPLED_POINTS = 50
OBSERVER_MARGIN = 0.08
CANDIDATE, FULL = "candidate:", "full:"


def resampled(path, points: int = RESAMPLED_POINTS) -> np.ndarray:
    """A path (T, G) as ``points`` points evenly spaced along its length (its first point where it never moves)."""
    path = np.asarray(path, dtype=np.float64)
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    if along[-1] <= 0:
        return np.repeat(path[:1], points, axis=0)
    at = np.linspace(0.0, along[-1], points)
    return np.stack([np.interp(at, along, path[:, k]) for k in range(path.shape[1])], axis=1)


def path_distance(a, b, points: int = RESAMPLED_POINTS) -> float:
    """Mean distance between two paths, point by point after :func:`resampled`."""
    return float(np.linalg.norm(resampled(a, points) - resampled(b, points), axis=1).mean())


def _tagged(records: list[TrajectoryRecord], tag: str) -> list[TrajectoryRecord]:
    return [replace(r, method=tag + r.method) for r in records]


def distances(full: list[TrajectoryRecord], other: list[TrajectoryRecord]) -> PairedDifference:
    """Mean path distance between ``other``'s and ``full``'s path of each forced style on each scene,
    with its scene-bootstrap interval (a distance, not a difference: ``b`` names the reference)."""
    values, scenes = [], []
    for style in (LEGIBLE, EFFICIENT):
        mine = {(r.scene_set, r.scene_index): r for r in other if r.method == style}
        ref = {(r.scene_set, r.scene_index): r for r in full if r.method == style}
        for key in sorted(set(mine) & set(ref), key=str):
            values.append(path_distance(mine[key].path, ref[key].path))
            scenes.append(key)
    return difference_of(values, scenes, "candidate", "full", "path_distance")


def _gap_difference(records: list[TrajectoryRecord], value, name: str) -> PairedDifference:
    """(candidate legible − efficient) − (full legible − efficient) of ``value``, ambiguous scenes."""
    ambiguous = [r for r in records if r.scene_set == AMBIGUOUS]
    table, scenes = matched(ambiguous, (CANDIDATE + LEGIBLE, CANDIDATE + EFFICIENT, FULL + LEGIBLE, FULL + EFFICIENT), value)
    diffs = (table[:, 0] - table[:, 1]) - (table[:, 2] - table[:, 3])
    kept = np.isfinite(diffs)
    return difference_of(diffs[kept], [s for s, k in zip(scenes, kept) if k], "candidate", "full", name)


def gap_share(records: list[TrajectoryRecord]) -> float:
    """The candidate's mean forced-style D̂ gap over the full planner's, ambiguous scenes."""
    def gap(tag):
        ambiguous = [r for r in records if r.scene_set == AMBIGUOUS]
        table, _ = matched(ambiguous, (tag + LEGIBLE, tag + EFFICIENT), lambda r: record_value(r, "d_hat"))
        return float((table[:, 0] - table[:, 1]).mean())
    full = gap(FULL)
    return gap(CANDIDATE) / full if full > 0 else float("nan")


def fidelity(full: list[TrajectoryRecord], candidate: list[TrajectoryRecord]) -> dict:
    """The three measures and the gap share of ``candidate`` against ``full`` (records of ``scdp_legible``
    and ``scdp_efficient`` on the same scenes, each with its ``scene_set`` and ``scene_index``)."""
    records = _tagged(full, FULL) + _tagged(candidate, CANDIDATE)
    observer = Measured(records, belief=Belief(PATH_LENGTH)).correct_at(MIDWAY)
    d_gap = _gap_difference(records, lambda r: record_value(r, "d_hat"), "d_hat_gap")
    o_gap = _gap_difference(records, observer, f"{PATH_LENGTH}_gap_at_{MIDWAY}")
    share = gap_share(records)
    return {"path_distance": distances(full, candidate).row(), "d_hat_gap": d_gap.row(), "observer_gap": o_gap.row(),
            "gap_share": share, "keeps_style": keeps_style(share, o_gap)}


def keeps_style(share: float, observer_gap: PairedDifference) -> bool:
    """The rule: at least :data:`MIN_GAP_SHARE` of the full planner's D̂ gap, and the observer-gap
    difference's lower bound above −:data:`OBSERVER_MARGIN`."""
    return bool(np.isfinite(share) and share >= MIN_GAP_SHARE and observer_gap.lo > -OBSERVER_MARGIN)
