"""The style-effect targets (issue 9), judged on paired records of the random-scene protocol.

Each target is a dict ``{task, target, holds, numbers}``; intervals are 95 % paired bootstrap
intervals (:func:`scdp.evaluation.statistics.compare`, resampling scenes where scenes repeat, as
when seeds are pooled), and an interval claim holds only when it excludes zero in the claimed
direction. Targets on T are judged on the failure-aware ``T_fa``
(:func:`scdp.metrics.failure_aware_transparency`), raw T shown beside it.

1. forced styles differ: D̂(scdp_legible) − D̂(scdp_efficient) >= 0.30 in ambiguous scenes
   (with its ratio to the gap between the training data's own style subsets, when given);
2. SCDP − Dataset T_fa >= +0.10 with the interval above zero, ambiguous and clear;
3. SCDP − DP T_fa above zero, ambiguous and clear;
4. SCDP − LD (tuned) T_fa above zero, ambiguous and clear (an interval below zero is said: LD wins);
5. success >= 0.98 for every method that ran (named in the target; the Dataset row is not a
   method), both sets.
"""

from __future__ import annotations

import numpy as np

from scdp.evaluation.records import FAILURE_AWARE
from scdp.evaluation.statistics import PairedDifference, compare
from scdp.evaluation.tables import DATASET, ordered_methods
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.metrics import MIN_SUCCESS

MIN_FORCED_GAP = 0.30
MIN_OVER_DATASET = 0.10


def _interval(c: PairedDifference) -> list[float]:
    return [round(c.mean, 3), round(c.lo, 3), round(c.hi, 3)]


def success_methods(methods) -> list[str]:
    """The methods the success target covers: every one that ran, the Dataset row excepted."""
    return ordered_methods(set(methods) - {DATASET})


def targets(records, subset_gaps: dict | None = None) -> list[dict]:
    """Every target each task's records can be judged on (a method that did not run is skipped).

    ``subset_gaps`` maps a task to the D̂ gap of its training data's style subsets in ambiguous
    scenes (:func:`scdp.scoring.subsets.subset_gaps`), to report the forced gap as a share of it.
    """
    out = []
    for task in sorted({r.task for r in records}):
        sets = {s: [r for r in records if r.task == task and r.scene_set == s] for s in (AMBIGUOUS, CLEAR)}
        methods = {r.method for r in sets[AMBIGUOUS]}

        def add(name, holds, numbers, task_name: str = task):  # bound now (add is only called in this iteration)
            out.append({"task": task_name, "target": name, "holds": bool(holds), "numbers": numbers})

        if {"scdp_legible", "scdp_efficient"} <= methods:
            c = compare(sets[AMBIGUOUS], "scdp_legible", "scdp_efficient", "d_hat")
            numbers = {"legible_minus_efficient_d_hat": _interval(c)}
            gap = (subset_gaps or {}).get(task)
            if gap:
                numbers.update(subset_gap=round(gap, 3), share_of_subset_gap=round(c.mean / gap, 2))
            add(f"forced styles differ: D̂ legible − efficient >= {MIN_FORCED_GAP} (ambiguous)", c.mean >= MIN_FORCED_GAP,
                numbers)
        for other, bar, scene_sets in (("dataset", MIN_OVER_DATASET, (AMBIGUOUS, CLEAR)), ("dp", 0.0, (AMBIGUOUS, CLEAR)),
                                       ("ld", 0.0, (AMBIGUOUS, CLEAR))):
            if not {"scdp", other} <= methods:
                continue
            for s in scene_sets:
                c = compare(sets[s], "scdp", other, FAILURE_AWARE)
                raw = compare(sets[s], "scdp", other, "transparency")
                holds = c.lo > 0 and c.mean >= bar
                need = f">= +{bar:.2f}, " if bar else ""
                numbers = {"difference": _interval(c), "raw_T_difference": _interval(raw)}
                if c.hi < 0:  # said plainly when the other method wins
                    numbers["other_wins"] = f"{other} beats SCDP: the interval lies below 0"
                add(f"SCDP − {other} T_fa {need}interval above 0 ({s})", holds, numbers)
        covered = success_methods(m for s in (AMBIGUOUS, CLEAR) for m in {r.method for r in sets[s]})
        success = {f"{s}/{m}": float(np.mean([r.success for r in sets[s] if r.method == m]))
                   for s in (AMBIGUOUS, CLEAR) for m in covered if any(r.method == m for r in sets[s])}
        if success:
            add(f"success >= {MIN_SUCCESS} for every method ({', '.join(covered)}; Dataset row excluded) on {AMBIGUOUS}, {CLEAR}",
                min(success.values()) >= MIN_SUCCESS, {k: round(v, 3) for k, v in success.items()})
    return out


def targets_markdown(rows: list[dict]) -> str:
    lines = ["| task | target | holds | numbers |", "|---|---|---|---|"]
    lines += [f"| {r['task']} | {r['target']} | {'yes' if r['holds'] else '**no**'} | `{r['numbers']}` |" for r in rows]
    return "\n".join(lines) + "\n"
