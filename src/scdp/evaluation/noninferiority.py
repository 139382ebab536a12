"""Is a candidate planner no worse than the default? The real-time gate's verdict (issue 50).

Both planners plan the same scenes, from the same start states, and each record of the candidate
pairs with the default's record of the same method and scene. For every task the candidate passes
when each check below holds; ``fast - default`` is a paired difference, and its one-sided 95 %
lower bound is the lower end of a 90 % scene-bootstrap interval (:data:`ONE_SIDED_LEVEL`):

* :data:`BOUNDS`: the lower bound of each listed measure is at or above its margin, for each listed
  method (``None``: every method that ran) in its scene set;
* success: the candidate's success rate is at least :data:`GATE_MIN_SUCCESS` for every method and set;
* forced-style gap: in each scene set, the candidate's ``scdp_legible - scdp_efficient`` gap in
  mean D̂ is at least :data:`MIN_GAP_SHARE` of the default's.

Margins are written here once, before any run of the gate; :func:`verdict` is what every caller uses
(the benchmark, its null check and its sensitivity check) and what the tests exercise.

Round 2 (issue 59, :func:`round_two`) keeps the D̂, Ê, observer, success and forced-gap checks and
takes its T_fa margins from the effects they protect, under both normalisations of D̂ and Ê
(:mod:`scdp.scoring.normalisation`):

* **T_fa, per cell**: for each task, scene set and reading, every method's margin is half the smallest
  |SCDP − X| T_fa effect of the committed run in that cell whose 95 % interval excludes zero, X the
  methods the claims and targets compare SCDP with (:data:`PROTECTED`: DP, tuned LD, the Dataset row);
  a cell without one takes its reading's smallest margin;
* **contrast**: ``(candidate SCDP − candidate DP) − (default SCDP − default DP)`` in T_fa, per cell: its
  one-sided 95 % lower bound must be at or above half the committed SCDP − DP effect of that cell (a
  cell where that effect is not established takes its reading's smallest), so the cell with the
  smallest effect is held to half of it. A candidate that erased SCDP's advantage over DP where it is
  smallest fails here even when each method's own T_fa bound holds.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from scdp.evaluation.adaptivity import MIDWAY
from scdp.evaluation.normalised import under
from scdp.evaluation.observation import PATH_LENGTH, Belief, Measured
from scdp.evaluation.records import FAILURE_AWARE, TrajectoryRecord, record_value
from scdp.evaluation.statistics import bootstrap_interval, compare_values, matched
from scdp.keys import AMBIGUOUS, CLEAR, DATASET_NORMALISATION, SCENE_NORMALISATION

CANDIDATE = "candidate:"  # prefix of the candidate's method names while both planners' records are paired
ONE_SIDED_LEVEL = 0.90  # two-sided coverage whose lower end is a one-sided 95 % bound
READ = f"{PATH_LENGTH}_correct_at_{MIDWAY}"  # the path-length observer right (1) or wrong (0) at half the motion
GATE_MIN_SUCCESS = 0.99
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


@dataclass(frozen=True)
class Rules:
    """A gate's margins. ``bounds``: on the per-scene reading, as round 1; ``t_fa[reading][task/scene set]``:
    the T_fa margin of every method in that cell under that reading; ``contrast[reading][task/scene set]``:
    the margin of the SCDP − DP contrast, candidate against default, in that cell."""

    bounds: tuple[Bound, ...] = BOUNDS
    t_fa: dict = field(default_factory=dict)
    contrast: dict = field(default_factory=dict)


ROUND_ONE = Rules()
CONTRAST = ("scdp", "dp")
PROTECTED = ("dp", "ld", "dataset")  # SCDP's effects the claims and targets are about (scdp.evaluation.targets)
PROTECTED_SHARE = 0.5  # a margin is half the smallest effect it protects


def _half_effects(rows: list[dict], others: tuple[str, ...]) -> dict[str, float]:
    """Per ``task/scene set``: −½ × the smallest |SCDP − X| T_fa effect (X in ``others``) whose 95 %
    interval excludes zero; a cell without one takes the smallest such margin of all the cells."""
    cells: dict = {}
    for r in rows:
        if r["a"] == "scdp" and r["b"] in others and r["metric"] == FAILURE_AWARE and r["scene_set"] in (AMBIGUOUS, CLEAR):
            found = cells.setdefault(f"{r['task']}/{r['scene_set']}", [])
            if r["lo"] > 0 or r["hi"] < 0:
                found.append(abs(r["mean"]))
    smallest = min(min(v) for v in cells.values() if v)
    return {cell: -PROTECTED_SHARE * (min(v) if v else smallest) for cell, v in sorted(cells.items())}


def round_two(committed: dict) -> Rules:
    """The round-2 rules (module docstring) from a committed run's ``claims.json`` (its paired T_fa
    differences under both readings). Deterministic: the same file gives the same margins."""
    readings = {SCENE_NORMALISATION: committed["paired_differences"],
                DATASET_NORMALISATION: committed[DATASET_NORMALISATION]["paired_differences"]}
    return Rules(tuple(b for b in BOUNDS if b.measure != FAILURE_AWARE),
                 {reading: _half_effects(rows, PROTECTED) for reading, rows in readings.items()},
                 {reading: _half_effects(rows, CONTRAST[1:]) for reading, rows in readings.items()})


def _reading_checks(records: list[TrajectoryRecord], task: str, methods: list[str], ran: list[str], rules: Rules,
                    ranges: dict | None) -> list[dict]:
    """The per-cell T_fa bounds and the SCDP − DP contrast of ``rules``, under each reading."""
    out = []
    for reading in dict.fromkeys([*rules.t_fa, *rules.contrast]):
        if reading != SCENE_NORMALISATION and task not in (ranges or {}):
            out.append({"check": "reading", "reading": reading, "holds": False, "missing": True})
            continue
        read = under(records, reading, ranges)
        for scene_set in (AMBIGUOUS, CLEAR):
            subset = [r for r in read if r.scene_set == scene_set]
            margin = rules.t_fa.get(reading, {}).get(f"{task}/{scene_set}")
            for method in methods if margin is not None else ():
                check = {"check": "bound", "measure": FAILURE_AWARE, "reading": reading, "scene_set": scene_set,
                         "method": method, "margin": margin}
                if method not in ran:
                    out.append(check | {"holds": False, "missing": True})
                    continue
                c = compare_values(subset, CANDIDATE + method, method, lambda r: record_value(r, FAILURE_AWARE),
                                   FAILURE_AWARE, level=ONE_SIDED_LEVEL)
                out.append(check | {"mean": c.mean, "lo": c.lo, "n": c.n, "holds": bool(c.lo >= margin)})
            if f"{task}/{scene_set}" in rules.contrast.get(reading, {}):
                out.append(_contrast(subset, scene_set, reading, rules.contrast[reading][f"{task}/{scene_set}"], ran))
    return out


def _contrast(records: list[TrajectoryRecord], scene_set: str, reading: str, margin: float, ran: list[str]) -> dict:
    """(candidate SCDP − candidate DP) − (default SCDP − default DP) in T_fa, per scene, and its bound."""
    a, b = CONTRAST
    check = {"check": "contrast", "measure": FAILURE_AWARE, "reading": reading, "scene_set": scene_set,
             "method": f"{a} - {b}", "margin": margin}
    if not {a, b} <= set(ran):
        return check | {"holds": False, "missing": True}
    values, _ = matched(records, (CANDIDATE + a, CANDIDATE + b, a, b), lambda r: record_value(r, FAILURE_AWARE))
    diffs = values[:, 0] - values[:, 1] - (values[:, 2] - values[:, 3])
    lo, _ = bootstrap_interval(diffs, level=ONE_SIDED_LEVEL)
    return check | {"mean": float(diffs.mean()), "lo": lo, "n": int(len(diffs)), "holds": bool(lo >= margin)}


def _value(measure: str, records: list[TrajectoryRecord]):
    """A per-record reader of ``measure``: the observer's reading, or a record metric."""
    if measure == READ:
        return Measured(records, belief=Belief(PATH_LENGTH)).correct_at(MIDWAY)
    return lambda r: record_value(r, measure)


def _bound_checks(records: list[TrajectoryRecord], methods: list[str], ran: list[str], bounds=BOUNDS) -> list[dict]:
    out = []
    for bound in bounds:
        subset = [r for r in records if r.scene_set == bound.scene_set]
        value = _value(bound.measure, subset) if subset else None
        for method in bound.methods or methods:
            check = {"check": "bound", "measure": bound.measure, "scene_set": bound.scene_set, "method": method,
                     "margin": bound.margin}
            if method not in ran:
                out.append(check | {"holds": False, "missing": True})
                continue
            c = compare_values(subset, CANDIDATE + method, method, value, bound.measure, level=ONE_SIDED_LEVEL)
            out.append(check | {"mean": c.mean, "lo": c.lo, "n": c.n, "holds": bool(c.lo >= bound.margin)})
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
                        "holds": bool(runs) and rate >= GATE_MIN_SUCCESS})
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


def verdict(default: list[TrajectoryRecord], candidate: list[TrajectoryRecord], rules: Rules = ROUND_ONE,
            ranges: dict | None = None) -> dict:
    """Every check of the module docstring, per task: ``{"passes", "tasks": {task: {"passes", "checks"}}}``.
    ``default`` and ``candidate`` hold each method's records under the method's own name, with scene
    indices, on the same scenes; a method or forced style missing from either fails its checks.
    ``rules``: round 1's margins, or :func:`round_two`'s; ``ranges``: each task's training-data range
    (:class:`~scdp.scoring.DatasetRange`), for the checks read over the training data."""
    out = {"tasks": {}}
    for task in sorted({r.task for r in default}):
        mine = [r for r in default if r.task == task]
        theirs = [replace(r, method=CANDIDATE + r.method) for r in candidate if r.task == task]
        planned = {r.method[len(CANDIDATE):] for r in theirs}
        methods = sorted({r.method for r in mine} | planned)  # either planner's
        ran = sorted({r.method for r in mine} & planned)  # both planners'
        records = mine + theirs
        checks = (_bound_checks(records, methods, ran, rules.bounds) + _reading_checks(records, task, methods, ran, rules, ranges)
                  + _success_checks(records, methods) + _gap_checks(records, ran))
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
            where = " ".join(str(c[k]) for k in ("method", "scene_set", "reading") if k in c)
            if c.get("missing"):
                lines.append(f"{task}: {c['check']} {where}: a method did not run")
            elif c["check"] in ("bound", "contrast"):
                name = f"contrast {c['measure']}" if c["check"] == "contrast" else c["measure"]
                lines.append(f"{task}: {name} {where}: lower bound {c['lo']:+.3f} < margin {c['margin']:+.3f} "
                             f"(mean {c['mean']:+.3f})")
            elif c["check"] == "success":
                lines.append(f"{task}: success {where}: {c['rate']:.3f} < {GATE_MIN_SUCCESS}")
            else:
                lines.append(f"{task}: forced-style D̂ gap {where}: {c['candidate']:.3f} is {100 * c['share']:.0f} % of "
                             f"the default's {c['default']:.3f} (< {100 * MIN_GAP_SHARE:.0f} %)")
    return lines
