"""Scene-clustered bootstrap: repeats of a scene and pooled seeds are resampled as one scene."""

from dataclasses import replace

import numpy as np
import pytest

from scdp.evaluation.records import TrajectoryRecord, scene_key
from scdp.evaluation.statistics import bootstrap_interval, cluster_bootstrap_interval, compare, paired_scenes, success_rate, wilson_interval


def _record(method, index, t, *, scene_set="ambiguous", seed=None, target=0, success=True):
    return TrajectoryRecord(task="navigation", scene_set=scene_set, method=method, goals=[[0, 0], [1, 1]], target=target,
                            path=[[0, 0]], success=success, bounds={}, j_hat=0.0,
                            metrics={"transparency": t, "d_hat": t, "e_hat": -t}, beta=4.0, scene_index=index,
                            training_seed=seed)


def _scene_effects(n=40):
    return np.random.default_rng(7).normal(0.1, 0.2, n)


def test_one_value_per_cluster_is_the_plain_bootstrap_exactly():
    values = _scene_effects()
    assert cluster_bootstrap_interval(values, list(range(len(values))), seed=3) == bootstrap_interval(values, seed=3)


def test_a_duplicated_scene_counts_once():
    """Each scene three times (as three seeds that agree): resampling scenes gives the plain interval
    of the 40 scene values, wider than the naive interval over 120 "independent" values."""
    v = _scene_effects()
    tripled, clusters = np.repeat(v, 3), np.repeat(np.arange(len(v)), 3)
    clustered = cluster_bootstrap_interval(tripled, clusters)
    assert clustered == pytest.approx(bootstrap_interval(v), abs=1e-12)
    naive = bootstrap_interval(tripled)
    assert clustered[1] - clustered[0] > 1.5 * (naive[1] - naive[0])  # about sqrt(3) wider


def test_pooled_seeds_pair_within_a_seed_and_resample_scenes():
    effects = _scene_effects()
    records = [_record(m, i, (0.5 + e if m == "scdp" else 0.5) + 0.001 * seed, seed=seed)
               for seed in (0, 1, 2) for i, e in enumerate(effects) for m in ("scdp", "dp")]
    diffs, scenes = paired_scenes(records, "scdp", "dp", lambda r: r.metrics["transparency"])
    assert len(diffs) == 120 and len(set(scenes)) == 40  # pairs never cross seeds; seeds share scenes
    c = compare(records, "scdp", "dp", "transparency")
    naive = compare(records, "scdp", "dp", "transparency", clustered=False)
    assert (c.n, c.scenes) == (120, 40) and c.mean == pytest.approx(effects.mean())
    assert (c.lo, c.hi) == pytest.approx(bootstrap_interval(effects), abs=1e-9)
    assert c.hi - c.lo > 1.5 * (naive.hi - naive.lo)


def test_one_record_per_scene_keeps_todays_numbers():
    effects = _scene_effects()
    records = [_record("scdp", i, 0.5 + e) for i, e in enumerate(effects)] + [_record("dp", i, 0.5) for i in range(40)]
    c = compare(records, "scdp", "dp", "transparency")
    diffs = np.array([0.5 + e - 0.5 for e in effects])
    assert c.scenes == c.n == 40
    assert (c.lo, c.hi) == bootstrap_interval(diffs)


def test_layout_repeats_are_one_scene_per_target():
    """Scene index 2 * repeat + target: five repeats of layout 1 hold two scenes, not ten."""
    runs = [_record("dp", i, 0.1 * i, scene_set="layout_1", target=i % 2) for i in range(10)]
    assert len({scene_key(r) for r in runs}) == 2
    assert scene_key(runs[0]) == scene_key(runs[8]) != scene_key(runs[1])
    assert scene_key(_record("dp", 3, 0.0)) == ("navigation", "ambiguous", 3)
    assert scene_key(replace(_record("dp", 3, 0.0), training_seed=5)) == scene_key(_record("dp", 3, 0.0))
    other = [replace(r, method="scdp", metrics={**r.metrics, "transparency": r.metrics["transparency"] + (0.3 if r.target else 0.0)})
             for r in runs]
    c = compare(runs + other, "scdp", "dp", "transparency")
    # two scenes, differences 0 (target 0) and 0.3 (target 1): a resampled mean is 0, 0.15 or 0.3
    assert (c.n, c.scenes) == (10, 2) and c.mean == pytest.approx(0.15)
    assert c.lo == pytest.approx(0.0) and c.hi == pytest.approx(0.3)


def test_wilson_interval_and_success_counted_on_scenes():
    z2 = 1.959963984540054 ** 2
    assert wilson_interval(1.0, 100) == pytest.approx((100 / (100 + z2), 1.0))  # 100 of 100: lo = n / (n + z²)
    lo, hi = wilson_interval(0.5, 4)
    assert lo == pytest.approx(1 - hi) and (lo, hi) == pytest.approx((0.1500, 0.8500), abs=1e-4)
    runs = [_record("ld", i, 0.0, scene_set="layout_2", target=i % 2, success=i != 3) for i in range(10)]
    s = success_rate(runs)
    assert (s["mean"], s["n"], s["scenes"]) == (0.9, 10, 2)
    assert (s["lo"], s["hi"]) == pytest.approx(wilson_interval(0.9, 2))
