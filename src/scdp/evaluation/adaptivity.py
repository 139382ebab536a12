"""Adaptivity, measured directly: how much of each forced style's advantage a planner keeps where it matters.

T mixes detachment and efficiency with a weight that depends on the scene, so a planner that is
always legible scores almost as high as one that is legible only when needed (issue 36: +0.014 T
on Block Reach's confirmation scenes). Here the two halves of "legible only when needed" are
measured apart, each against SCDP's own forced styles on the same scenes and noise
(``scdp_legible`` L, ``scdp_efficient`` E, planner P):

* **ambiguous scenes, legible share kept**: ``Σ (m(P) - m(E)) / Σ (m(L) - m(E))`` over the scenes,
  for m = D̂ and each observer's accuracy at 50 % of the motion. 1: P gains all that the legible
  style gains over the efficient one; 0: none of it;
* **clear scenes, efficient share kept**: ``Σ (m(P) - m(L)) / Σ (m(E) - m(L))`` for m = Ê and the
  path length. 1: P is as efficient as the efficient style; 0: as wasteful as the legible one.

An always-legible planner scores 1 and 0, an always-efficient one 0 and 1; a planner legible
exactly when needed scores 1 and 1. Each share carries a 95 % percentile interval over the scenes
resampled (:func:`scdp.evaluation.statistics.cluster_bootstrap_ratio`); a share whose
denominator's own interval includes zero (the styles do not differ there) is flagged
``styles_differ: false`` and says nothing.
"""

from __future__ import annotations

import numpy as np

from scdp import metrics
from scdp.evaluation.observation import measure_all
from scdp.evaluation.records import TrajectoryRecord, record_value
from scdp.evaluation.statistics import bootstrap_interval, cluster_bootstrap_interval, cluster_bootstrap_ratio, matched
from scdp.keys import AMBIGUOUS, CLEAR, LD_METHODS

LEGIBLE, EFFICIENT = "scdp_legible", "scdp_efficient"
PLANNERS = ("dp", *LD_METHODS, "scdp", "scdp_blend", "scdp_paper", LEGIBLE, EFFICIENT)
MIDWAY = 50  # the observers' accuracy is read at this percent of the motion


def path_length(record: TrajectoryRecord) -> float:
    """The stored path's length (m): ``1 / E`` (:func:`scdp.metrics.efficiency`) without its epsilon."""
    return metrics.path_length(record.path)


def share(records: list[TrajectoryRecord], planner: str, towards: str, away: str, value, *, seed: int = 0) -> dict:
    """The share ``Σ (v(planner) - v(away)) / Σ (v(towards) - v(away))`` over the scenes all three ran,
    with its interval, and the interval of the denominator (the styles' own gap)."""
    values, scenes = matched(records, (planner, towards, away), value)
    keep = np.isfinite(values).all(axis=1)
    values, scenes = values[keep], [s for s, k in zip(scenes, keep) if k]
    kept, gap = values[:, 0] - values[:, 2], values[:, 1] - values[:, 2]
    ratio, lo, hi = cluster_bootstrap_ratio(kept, gap, scenes, seed=seed)
    if len(set(scenes)) < len(scenes):
        gap_lo, gap_hi = cluster_bootstrap_interval(gap, scenes, seed=seed)
    else:
        gap_lo, gap_hi = bootstrap_interval(gap, seed=seed)
    return {"share": ratio, "lo": lo, "hi": hi, "n": int(len(kept)), "scenes": len(set(scenes)),
            "style_gap": float(gap.mean()) if len(gap) else float("nan"), "style_gap_lo": gap_lo, "style_gap_hi": gap_hi,
            "styles_differ": bool(gap_lo > 0 or gap_hi < 0)}


def measures(measured: dict) -> dict:
    """The measures of each side: ``{scene set: {name: value of a record}}``; ``measured`` maps each
    observer to its :class:`~scdp.evaluation.observation.Measured`
    (:func:`~scdp.evaluation.observation.measure_all`)."""
    ambiguous = {"d_hat": lambda r: record_value(r, "d_hat")}
    ambiguous |= {f"{observer}_correct_at_{MIDWAY}": m.correct_at(MIDWAY) for observer, m in measured.items()}
    clear = {"e_hat": lambda r: record_value(r, "e_hat"), "path_length": path_length}
    return {AMBIGUOUS: ambiguous, CLEAR: clear}


def adaptivity(records: list[TrajectoryRecord], measured: dict | None = None, planners=PLANNERS) -> list[dict]:
    """One row per task, planner and measure: the legible share kept in ambiguous scenes (D̂, each
    observer's accuracy at 50 %) and the efficient share kept in clear scenes (Ê, path length).
    ``measured``: the records' :func:`~scdp.evaluation.observation.measure_all` (computed when not given)."""
    measured = measure_all(records) if measured is None else measured
    rows = []
    for task in sorted({r.task for r in records}):
        for scene_set, named in measures(measured).items():
            group = [r for r in records if r.task == task and r.scene_set == scene_set]
            ran = {r.method for r in group}
            if not {LEGIBLE, EFFICIENT} <= ran:
                continue
            towards, away = (LEGIBLE, EFFICIENT) if scene_set == AMBIGUOUS else (EFFICIENT, LEGIBLE)
            for planner in (p for p in planners if p in ran):
                for name, value in named.items():
                    rows.append({"task": task, "scene_set": scene_set, "planner": planner, "measure": name,
                                 "kept": f"{towards} over {away}", **share(group, planner, towards, away, value)})
    return rows


def adaptivity_markdown(rows: list[dict]) -> str:
    """A table per task: a row per planner, a column per measure (share [95 % interval])."""
    lines = ["Share of the forced styles' advantage each planner keeps, on the same scenes and noise: in ambiguous "
             "scenes Σ(P − efficient) / Σ(legible − efficient), in clear scenes Σ(P − legible) / Σ(efficient − legible); "
             "1 keeps all of it, 0 none. Always legible scores 1 and 0, always efficient 0 and 1, legible exactly when "
             f"needed 1 and 1. Observers read at {MIDWAY} % of the motion. 95 % intervals resample scenes; † marks a "
             "measure on which the two forced styles do not differ (their gap's interval includes zero), where the "
             "share says nothing.", ""]
    columns = list(dict.fromkeys((r["scene_set"], r["measure"]) for r in rows))
    for task in dict.fromkeys(r["task"] for r in rows):
        cells: dict = {}
        for r in rows:
            if r["task"] == task:
                mark = "" if r["styles_differ"] else " †"
                cells.setdefault(r["planner"], {})[(r["scene_set"], r["measure"])] = \
                    f"{r['share']:.2f} [{r['lo']:.2f}, {r['hi']:.2f}]{mark}"
        lines += [f"**{task}**", "", "| planner | " + " | ".join(f"{s}: {m.replace('_', ' ')}" for s, m in columns) + " |",
                  "|---|" + "---|" * len(columns)]
        lines += [f"| {planner} | " + " | ".join(row.get(c, "–") for c in columns) + " |" for planner, row in cells.items()]
        lines.append("")
    return "\n".join(lines)
