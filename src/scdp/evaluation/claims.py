"""The paper's four claims, judged on our numbers (``claims.json`` and the report's table).

Claims that compare T between methods are judged on the failure-aware ``T_fa``
(:func:`scdp.metrics.failure_aware_transparency`: a failed run never scores above 0), with
raw T shown beside it. Every claim names the methods and scene sets it covers: the paper's
comparisons cover its three methods (dp, ld, scdp); "success >= 0.98 for every method" covers
every method that ran (the Dataset row, the generator's demonstrations, is not a method and is
left out, by name).
"""

from __future__ import annotations

from scdp.evaluation.records import FAILURE_AWARE
from scdp.evaluation.statistics import compare
from scdp.evaluation.statistics import holds as interval_holds
from scdp.evaluation.tables import DATASET, LAYOUT_GROUPS, SETS, ordered_methods
from scdp.metrics import MIN_SUCCESS

PAPER_METHODS = ("dp", "ld", "scdp")


def _t_fa(stat: dict) -> float:
    """A summary's mean T_fa (summaries written before it existed: raw T)."""
    return stat.get(FAILURE_AWARE, stat["transparency"])["mean"]


def success_claim(task_sets: dict, scene_sets) -> dict:
    """"success >= 0.98 for every method" over every method that ran in any of ``scene_sets``,
    naming the methods and the sets; numbers: the cells below 0.98 (or the lowest), and what it covers."""
    methods = ordered_methods({m for s in scene_sets for m in task_sets[s]} - {DATASET})
    cells = {f"{s}/{m}": task_sets[s][m]["success"]["mean"] for s in scene_sets for m in methods if m in task_sets[s]}
    low = {k: round(v, 3) for k, v in cells.items() if v < MIN_SUCCESS} or {"min": round(min(cells.values()), 3)}
    return {"claim": f"success >= {MIN_SUCCESS} for every method ({', '.join(methods)}; Dataset row excluded) "
                     f"on {', '.join(scene_sets)}",
            "holds": min(cells.values()) >= MIN_SUCCESS,
            "numbers": {**low, "methods": methods, "scene_sets": list(scene_sets)}}


def claims(summary: dict, scene_sets: tuple[str, str] = SETS, protocol: str = "random", records=None) -> list[dict]:
    """The paper's four claims, judged on our numbers.

    ``scene_sets`` names the (ambiguous, clear) sets to judge on: the random scene sets, or
    :data:`~scdp.evaluation.tables.LAYOUT_GROUPS` for the per-layout protocol. A task that lacks
    one of them (``reproduce --layouts`` ran only some layouts) is not judged. With the
    ``records``, "SCDP beats DP" holds only when the 95 % bootstrap interval of the paired
    difference in T_fa lies above zero (:mod:`scdp.evaluation.statistics`), and "SCDP has the
    best T_fa" only when its intervals against DP and LD both do; without them, when the mean is
    higher. On the random sets, the success claim is also judged on the layout groups when they
    ran, as its own row.
    """
    out = []
    names = ", ".join(PAPER_METHODS)
    for task, sets in summary.items():
        if not all(s in sets for s in scene_sets):
            continue
        amb, clear = sets[scene_sets[0]], sets[scene_sets[1]]
        t_fa = {m: _t_fa(clear[m]) for m in PAPER_METHODS}
        best = max(t_fa, key=t_fa.get) == "scdp"
        numbers = {"T_fa": {m: round(v, 3) for m, v in t_fa.items()},
                   "T": {m: round(clear[m]["transparency"]["mean"], 3) for m in PAPER_METHODS}}
        paired = [r for r in records or [] if r.task == task and r.scene_set == scene_sets[1]]
        if paired:
            versus = {other: compare(paired, "scdp", other, FAILURE_AWARE) for other in ("dp", "ld")}
            best = all(interval_holds(c, ">") for c in versus.values())
            numbers.update({f"paired_difference_vs_{other}": [round(getattr(c, k), 3) for k in ("mean", "lo", "hi")]
                            for other, c in versus.items()})
        out.append({"task": task, "claim": f"SCDP has the best T_fa in non-ambiguous scenes (of {names})", "holds": best,
                    "numbers": numbers})
        numbers = {"T_fa": {m: round(_t_fa(amb[m]), 3) for m in ("dp", "scdp")},
                   "T": {m: round(amb[m]["transparency"]["mean"], 3) for m in ("dp", "scdp")}}
        beats = numbers["T_fa"]["scdp"] > numbers["T_fa"]["dp"]
        paired = [r for r in records or [] if r.task == task and r.scene_set == scene_sets[0]]
        if paired:
            c = compare(paired, "scdp", "dp", FAILURE_AWARE)
            raw = compare(paired, "scdp", "dp", "transparency")
            beats = interval_holds(c, ">")
            numbers["paired_difference"] = [c.mean, c.lo, c.hi]  # T_fa, full precision: the verdict follows from them
            numbers["paired_difference_raw_T"] = [raw.mean, raw.lo, raw.hi]
        out.append({"task": task, "claim": "SCDP beats DP in ambiguous scenes (T_fa)", "holds": beats, "numbers": numbers})
        for s in scene_sets:
            d = {m: sets[s][m]["d_hat"]["mean"] for m in PAPER_METHODS}
            e = {m: sets[s][m]["e_hat"]["mean"] for m in PAPER_METHODS}
            holds = max(d, key=d.get) == "ld" and min(e, key=e.get) == "ld"
            out.append({"task": task, "claim": f"LD is the most detached and the least efficient (of {names}; {s})", "holds": holds,
                        "numbers": {"d_hat": {m: round(v, 3) for m, v in d.items()}, "e_hat": {m: round(v, 3) for m, v in e.items()}}})
        out.append({"task": task, **success_claim(sets, scene_sets)})
        if tuple(scene_sets) != LAYOUT_GROUPS and all(g in sets for g in LAYOUT_GROUPS):
            out.append({"task": task, **success_claim(sets, LAYOUT_GROUPS)})
    return [{**c, "protocol": protocol} for c in out]
