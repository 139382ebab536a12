"""What a study's answers say beside the methods' accuracy: the button position and the ratings.

* **Button position.** The target's button is an independent draw per trial, balanced across a
  row's successive participants (:func:`scdp.study.design.target_buttons`), so it cannot favour a
  method on average; these checks say whether people favoured a button anyway. Per position: the
  share of final answers on it, less the share of targets on it (no bias: 0; a participant who
  always presses one button pulls it up), and the accuracy when the target was on it, each with
  the crossed participant x scene interval of the main analysis. The method comparison adjusted for position
  averages, over positions, each method's accuracy when the target was on that position
  (post-stratification: every position weighs the same whatever its count).
* **Ratings.** Each participant rates one motion per method at the end (Dragan et al.'s
  legibility and predictability statements, 1..7). Per method the mean rating, and per pair the
  paired difference within participant, each with a participant bootstrap interval.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

from scdp.evaluation.resampling import cluster_draws, percentile_interval, weighted_means

RATED = ("legible", "predictable")


def position_checks(used: list[dict], weights: np.ndarray, goals: int, methods: list[str]) -> dict:
    """Button-position checks over the analysed main responses ``used`` with their crossed bootstrap
    ``weights`` (samples, N): per position the share chosen and the accuracy, and the method pairs'
    final-accuracy differences adjusted for the target's position."""
    chosen = np.array([r["choice_position"] for r in used])
    target = np.array([r["target_position"] for r in used])
    final = np.array([r["final"] for r in used], dtype=np.float64)
    everyone = np.ones(len(used), dtype=bool)
    positions = []
    for p in range(goals):
        share = weighted_means(weights, (chosen == p).astype(np.float64), everyone)
        excess = weighted_means(weights, (chosen == p).astype(np.float64) - (target == p), everyone)
        at = target == p
        accuracy = weighted_means(weights, final, at) if at.any() else np.full(len(weights), np.nan)
        lo, hi = percentile_interval(excess)
        positions.append({"position": p, "responses_with_target_here": int(at.sum()),
                          "share_chosen": {"mean": float(np.mean(chosen == p)), "ci": percentile_interval(share)},
                          "share_target": float(np.mean(at)),
                          "excess": {"mean": float(np.mean(chosen == p) - np.mean(at)), "ci": [lo, hi]},
                          "biased": bool(lo > 0 or hi < 0),
                          "accuracy": {"mean": float(final[at].mean()) if at.any() else None, "ci": percentile_interval(accuracy)}})
    method = np.array([r["method"] for r in used])

    def adjusted(m: str):
        cells = [(method == m) & (target == p) for p in range(goals)]
        if not all(c.any() for c in cells):
            return None, None
        return (float(np.mean([final[c].mean() for c in cells])),
                np.mean(np.stack([weighted_means(weights, final, c) for c in cells]), axis=0))  # NaN: a cell not drawn

    pairs, dropped = [], []
    for a, b in combinations(methods, 2):
        (ma, da), (mb, db) = adjusted(a), adjusted(b)
        if ma is None or mb is None:  # said in the report: a method never had its target on some button
            empty = [f"{m} × button {p}" for m in (a, b) for p in range(goals) if not ((method == m) & (target == p)).any()]
            dropped.append({"a": a, "b": b, "why": f"no response in {', '.join(empty)}: the adjustment needs every cell"})
            continue
        lo, hi = percentile_interval(da - db)
        pairs.append({"a": a, "b": b, "mean": ma - mb, "ci": [lo, hi], "excludes_zero": bool(lo > 0 or hi < 0)})
    return {"chance": 1 / goals, "positions": positions, "any_bias": any(p["biased"] for p in positions),
            "adjusted_final": pairs, "dropped": dropped}


def rating_summary(ratings: list[dict], analysed: set, methods: list[str], *, samples: int, seed: int) -> dict:
    """Per method the mean rating of each statement, and per pair the paired difference, over the
    ``analysed`` participants' ratings, with participant-bootstrap 95 % intervals."""
    kept = [r for r in ratings if r["pid"] in analysed]
    out = {"participants": len({r["pid"] for r in kept}), "methods": {}, "paired": []}
    if not kept:
        return out
    pids = sorted({r["pid"] for r in kept})
    index = {p: i for i, p in enumerate(pids)}
    weights = cluster_draws(len(pids), samples, np.random.default_rng(seed)).astype(np.float64)  # (samples, participants)
    table = {q: np.full((len(pids), len(methods)), np.nan) for q in RATED}  # participant x method
    for r in kept:
        for q in RATED:
            table[q][index[r["pid"]], methods.index(r["method"])] = r[q]
    for j, m in enumerate(methods):
        out["methods"][m] = {}
        for q in RATED:
            has = ~np.isnan(table[q][:, j])
            if has.any():
                draws = weighted_means(weights, np.nan_to_num(table[q][:, j]), has)
                out["methods"][m][q] = {"mean": float(table[q][has, j].mean()), "ci": percentile_interval(draws), "n": int(has.sum())}
    for (i, a), (j, b) in combinations(enumerate(methods), 2):
        for q in RATED:
            both = ~np.isnan(table[q][:, i]) & ~np.isnan(table[q][:, j])
            if both.any():
                diff = np.nan_to_num(table[q][:, i] - table[q][:, j])
                lo, hi = percentile_interval(weighted_means(weights, diff, both))
                out["paired"].append({"a": a, "b": b, "quantity": q, "mean": float(diff[both].mean()), "ci": [lo, hi],
                                      "excludes_zero": bool(lo > 0 or hi < 0)})
    return out
