"""Is a candidate planner no worse than the default? The real-time gate's verdict (issue 50).

Both planners plan the same scenes, from the same start states, and each record of the candidate
pairs with the default's record of the same method and scene. For every task the candidate passes
when each check below holds; ``fast - default`` is a paired difference, and its one-sided 95 %
lower bound is the lower end of a 90 % scene-bootstrap interval (:data:`ONE_SIDED_LEVEL`):

* :data:`BOUNDS`: the lower bound of each listed measure is at or above its margin, for each listed
  method (``None``: every method that ran) in its scene set;
* success: the candidate's success rate is at least :data:`MIN_SUCCESS` for every method and set;
* forced-style gap: in each scene set, the candidate's ``scdp_legible - scdp_efficient`` gap in
  mean D̂ is at least :data:`MIN_GAP_SHARE` of the default's.

Margins are written here once, before any run of the gate; :func:`verdict` is what every caller uses
(the benchmark, its null check and its sensitivity check) and what the tests exercise.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from scdp.evaluation.adaptivity import MIDWAY
from scdp.evaluation.observation import PATH_LENGTH, Belief, Measured
from scdp.evaluation.records import FAILURE_AWARE, TrajectoryRecord, record_value
from scdp.evaluation.statistics import compare_values
from scdp.keys import AMBIGUOUS, CLEAR

CANDIDATE = "candidate:"  # prefix of the candidate's method names while both planners' records are paired
ONE_SIDED_LEVEL = 0.90  # two-sided coverage whose lower end is a one-sided 95 % bound
READ = f"{PATH_LENGTH}_correct_at_{MIDWAY}"  # the path-length observer right (1) or wrong (0) at half the motion
MIN_SUCCESS = 0.99
MIN_GAP_SHARE = 0.90
FORCED = ("scdp_legible", "scdp_efficient")


@dataclass(frozen=True)
class Bound:
    """``candidate - default`` of ``measure`` in ``scene_set``: its one-sided 95 % lower bound must
    be >= ``margin`` (a negative number: the loss tolerated) for each of ``methods`` (None: all)."""

    measure: str
    scene_set: str
    margin: float
    methods: tuple[str, ...] | None = None


BOUNDS = (
    Bound(FAILURE_AWARE, AMBIGUOUS, -0.025),
    Bound(FAILURE_AWARE, CLEAR, -0.025),
    Bound("d_hat", AMBIGUOUS, -0.05, ("scdp", "scdp_legible")),
    Bound("e_hat", CLEAR, -0.05, ("scdp", "scdp_efficient")),
    Bound(READ, AMBIGUOUS, -0.08, ("scdp", "scdp_legible")),  # 0/1 per scene: a wider margin at this N
)


def _value(measure: str, records: list[TrajectoryRecord]):
    """A per-record reader of ``measure``: the observer's reading, or a record metric."""
    if measure == READ:
        return Measured(records, belief=Belief(PATH_LENGTH)).correct_at(MIDWAY)
    return lambda r: record_value(r, measure)


def _bound_checks(records: list[TrajectoryRecord], methods: list[str], ran: list[str]) -> list[dict]:
    out = []
    for bound in BOUNDS:
        subset = [r for r in records if r.scene_set == bound.scene_set]
        value = _value(bound.measure, subset) if subset else None
        for method in bound.methods or methods:
            check = {"check": "bound", "measure": bound.measure, "scene_set": bound.scene_set, "method": method,
                     "margin": bound.margin}
            if method not in ran:
                out.append(check | {"holds": False, "missing": True})
                continue
            c = compare_values(subset, CANDIDATE + method, method, value, bound.measure, level=ONE_SIDED_LEVEL)
            out.append(check | {"mean": c["mean"], "lo": c["lo"], "n": c["n"], "holds": bool(c["lo"] >= bound.margin)})
    return out


def _success_checks(records: list[TrajectoryRecord], methods: list[str]) -> list[dict]:
    out = []
    for method in methods:
        for scene_set in (AMBIGUOUS, CLEAR):
            runs = [r.success for r in records if r.method == CANDIDATE + method and r.scene_set == scene_set]
            rate = float(np.mean(runs)) if runs else float("nan")
            out.append({"check": "success", "method": method, "scene_set": scene_set, "rate": rate,
                        "default_rate": float(np.mean([r.success for r in records if r.method == method
                                                       and r.scene_set == scene_set] or [np.nan])),
                        "holds": bool(runs) and rate >= MIN_SUCCESS})
    return out


def _gap_checks(records: list[TrajectoryRecord], methods: list[str]) -> list[dict]:
    if not set(FORCED) <= set(methods):
        return [{"check": "forced_gap", "missing": True, "holds": False}]
    def gap(prefix: str, scene_set: str) -> float:  # mean D̂, forced legible - forced efficient
        legible, efficient = ([r.metrics["d_hat"] for r in records if r.method == prefix + m and r.scene_set == scene_set]
                              for m in FORCED)
        return float(np.mean(legible) - np.mean(efficient))

    out = []
    for scene_set in (AMBIGUOUS, CLEAR):
        default, candidate = gap("", scene_set), gap(CANDIDATE, scene_set)
        share = candidate / default if default > 0 else float("nan")
        out.append({"check": "forced_gap", "scene_set": scene_set, "default": default, "candidate": candidate,
                    "share": share, "holds": bool(share >= MIN_GAP_SHARE)})
    return out


def verdict(default: list[TrajectoryRecord], candidate: list[TrajectoryRecord]) -> dict:
    """Every check of the module docstring, per task: ``{"passes", "tasks": {task: {"passes", "checks"}}}``.
    ``default`` and ``candidate`` hold each method's records under the method's own name, with scene
    indices, on the same scenes; a method or forced style missing from either fails its checks."""
    out = {"tasks": {}}
    for task in sorted({r.task for r in default}):
        mine = [r for r in default if r.task == task]
        theirs = [replace(r, method=CANDIDATE + r.method) for r in candidate if r.task == task]
        planned = {r.method[len(CANDIDATE):] for r in theirs}
        methods = sorted({r.method for r in mine} | planned)  # either planner's
        ran = sorted({r.method for r in mine} & planned)  # both planners'
        records = mine + theirs
        checks = _bound_checks(records, methods, ran) + _success_checks(records, methods) + _gap_checks(records, ran)
        out["tasks"][task] = {"passes": all(c["holds"] for c in checks), "checks": checks}
    out["passes"] = bool(out["tasks"]) and all(t["passes"] for t in out["tasks"].values())
    return out


def failed(result: dict) -> list[str]:
    """One line per failed check of a :func:`verdict`, naming the check and by how much it missed."""
    lines = []
    for task, block in result["tasks"].items():
        for c in block["checks"]:
            if c["holds"]:
                continue
            where = " ".join(str(c[k]) for k in ("method", "scene_set") if k in c)
            if c.get("missing"):
                lines.append(f"{task}: {c['check']} {where}: a method did not run")
            elif c["check"] == "bound":
                lines.append(f"{task}: {c['measure']} {where}: lower bound {c['lo']:+.3f} < margin {c['margin']:+.3f} "
                             f"(mean {c['mean']:+.3f})")
            elif c["check"] == "success":
                lines.append(f"{task}: success {where}: {c['rate']:.3f} < {MIN_SUCCESS}")
            else:
                lines.append(f"{task}: forced-style D̂ gap {where}: {c['candidate']:.3f} is {100 * c['share']:.0f} % of "
                             f"the default's {c['default']:.3f} (< {100 * MIN_GAP_SHARE:.0f} %)")
    return lines
