"""Paired differences and their bootstrap intervals."""

import numpy as np
import pytest

from scdp.evaluation.records import TrajectoryRecord
from scdp.evaluation.statistics import bootstrap_interval, compare, holds, paired, paired_comparisons


def _record(method, index, t, scene_set="ambiguous", task="navigation"):
    return TrajectoryRecord(task=task, scene_set=scene_set, method=method, goals=[[0, 0], [1, 1]], target=0, path=[[0, 0]],
                            success=True, bounds={}, j_hat=0.0, metrics={"transparency": t, "d_hat": t, "e_hat": -t},
                            beta=4.0, scene_index=index)


def test_pairs_are_matched_by_scene_not_by_order():
    records = [_record("scdp", 1, 0.9), _record("scdp", 0, 0.5), _record("dp", 0, 0.4), _record("dp", 1, 0.1),
               _record("dp", 2, 0.3)]  # scene 2 only ran with dp: no pair
    diffs = paired(records, "scdp", "dp", lambda r: r.metrics["transparency"])
    assert sorted(np.round(diffs, 6)) == [0.1, 0.8]


def test_interval_covers_the_mean_and_shrinks_with_n():
    rng = np.random.default_rng(0)
    small, large = rng.normal(0.1, 0.2, 20), rng.normal(0.1, 0.2, 2000)
    lo_s, hi_s = bootstrap_interval(small)
    lo_l, hi_l = bootstrap_interval(large)
    assert lo_s < small.mean() < hi_s and lo_l < large.mean() < hi_l
    assert hi_l - lo_l < 0.3 * (hi_s - lo_s)
    assert bootstrap_interval(small, seed=3) == bootstrap_interval(small, seed=3)


def test_a_claim_holds_only_when_the_interval_excludes_zero():
    better = [_record("scdp", i, 0.5 + 0.01 * (i % 3)) for i in range(30)] + [_record("dp", i, 0.4) for i in range(30)]
    c = compare(better, "scdp", "dp", "transparency")
    assert c.n == 30 and c.mean == pytest.approx(0.11) and holds(c, ">") and not holds(c, "<")
    noisy = [_record("scdp", i, 0.4 + (0.2 if i % 2 else -0.19)) for i in range(30)] + [_record("dp", i, 0.4) for i in range(30)]
    c = compare(noisy, "scdp", "dp", "transparency")
    assert c.lo < 0 < c.hi and not holds(c, ">")


def test_comparisons_cover_each_pair_metric_and_set():
    records = [_record(m, i, 0.5, s) for m in ("scdp", "dp", "dataset") for i in range(3) for s in ("ambiguous", "non_ambiguous")]
    rows = paired_comparisons(records, ("ambiguous", "non_ambiguous"))
    assert {(r["a"], r["b"]) for r in rows} == {("scdp", "dp"), ("scdp", "dataset")}  # no ld records: no scdp - ld
    assert len(rows) == 2 * 2 * 4 and all(r["n"] == 3 for r in rows)  # T, T_fa, D̂, Ê


def test_style_targets_judge_margins_intervals_and_success():
    from dataclasses import replace

    from scdp.evaluation.targets import targets

    def scene(method, i, t, s, d=None, success=True):
        r = _record(method, i, t, scene_set=s)
        return replace(r, success=success, metrics={**r.metrics, "d_hat": t if d is None else d})

    records = []
    for s in ("ambiguous", "non_ambiguous"):
        for i in range(40):
            wobble = 0.01 * (i % 4)
            records += [scene("scdp", i, 0.60 + wobble, s), scene("dp", i, 0.55, s), scene("ld", i, 0.50, s),
                        scene("dataset", i, 0.52, s),  # SCDP beats it by 0.095: interval above 0, margin missed
                        scene("scdp_blend", i, 0.6, s, success=i != 0),  # one failure: 0.975 < 0.98
                        scene("scdp_legible", i, 0.5, s, d=0.7), scene("scdp_efficient", i, 0.5, s, d=0.3 + wobble)]
    judged = {r["target"]: r for r in targets(records, {"navigation": 0.8})}
    forced = judged["forced styles differ: D̂ legible − efficient >= 0.3 (ambiguous)"]
    assert forced["holds"] and forced["numbers"]["share_of_subset_gap"] == pytest.approx(0.385 / 0.8, abs=0.01)
    assert not judged["SCDP − dataset T_fa >= +0.10, interval above 0 (ambiguous)"]["holds"]
    assert judged["SCDP − dp T_fa interval above 0 (non_ambiguous)"]["holds"]
    assert judged["SCDP − ld T_fa interval above 0 (ambiguous)"]["holds"]
    assert judged["SCDP − ld T_fa interval above 0 (non_ambiguous)"]["holds"]  # LD is judged on both sets
    assert "other_wins" not in judged["SCDP − ld T_fa interval above 0 (ambiguous)"]["numbers"]
    flipped = [replace(r, metrics={**r.metrics, "transparency": 0.9}) if r.method == "ld" else r for r in records]
    lost = {r["target"]: r for r in targets(flipped)}["SCDP − ld T_fa interval above 0 (ambiguous)"]
    assert not lost["holds"] and "ld beats SCDP" in lost["numbers"]["other_wins"]
    every = "dp, ld, scdp, scdp_blend, scdp_legible, scdp_efficient; Dataset row excluded"
    success = judged[f"success >= 0.98 for every method ({every}) on ambiguous, non_ambiguous"]
    assert not success["holds"] and success["numbers"]["ambiguous/scdp_blend"] == 0.975
