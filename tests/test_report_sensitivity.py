"""The failure-aware score, "every method" claims, and the metric-sensitivity section of the report."""

import json
import math

import numpy as np
import pytest

from scdp import metrics
from scdp.evaluation import claims, sensitivity, tables, targets
from scdp.evaluation.records import TrajectoryRecord, record_value, summarize

GOALS = [[2.0, 0.2], [2.0, -0.2]]  # Navigation goals 0.4 m apart; target 0


def _record(method, index, path, *, scene_set="ambiguous", success=True, t=None, goals=GOALS):
    """A Navigation record whose stored metrics are scored from its path with our range (as the pipeline does)."""
    bounds = {"d_min": 0.0, "d_max": 10.0, "e_min": 0.0, "e_max": 1.0}
    r = TrajectoryRecord(task="navigation", scene_set=scene_set, method=method, goals=goals, target=0, path=path,
                         success=success, bounds=bounds, j_hat=0.0, metrics={}, beta=4.0, scene_index=index)
    m = sensitivity.rescore(r, sensitivity.box_range("navigation"))
    r.metrics = {"detachment": 0.0, "efficiency": 0.0, "d_hat": m["d_hat"], "e_hat": m["e_hat"],
                 "transparency": m["transparency"] if t is None else t, "legibility": 0.5}
    r.j_hat = m["j_hat"]
    return r


def _bent(k: float) -> list:
    """A path from the start towards g* (2, 0.2) bowing away from the distractor by k metres."""
    s = np.linspace(0, 1, 30)[:, None]
    return (s * np.array([2.0, 0.2]) + np.sin(np.pi * s) * np.array([0.0, k])).round(4).tolist()


def test_failure_aware_t_keeps_successes_and_floors_failures_at_zero():
    assert metrics.failure_aware_transparency(0.7, True) == 0.7
    assert metrics.failure_aware_transparency(-0.3, True) == -0.3  # a poor success keeps its score
    assert metrics.failure_aware_transparency(3.2, False) == 0.0  # a failed detour is not credited
    assert metrics.failure_aware_transparency(-1.5, False) == -1.5  # never lifted above its own T
    out = metrics.failure_aware_transparency(np.array([0.8, 0.8]), np.array([True, False]))
    assert out.tolist() == [0.8, 0.0]
    runs = [_record("ld_paper", i, _bent(0.0), success=i < 3, t=1.0 + i) for i in range(4)]  # T 1, 2, 3 succeed; 4 fails
    assert [record_value(r, "transparency_fa") for r in runs] == [1.0, 2.0, 3.0, 0.0]
    assert summarize(runs)["transparency_fa"]["mean"] == pytest.approx(1.5)
    assert summarize(runs)["transparency"]["mean"] == pytest.approx(2.5)


def test_bounded_t_clips_the_scores_to_the_reference_range_and_scores_a_failure_at_the_worst():
    w = float(metrics.ambiguity_weight(0.5))  # j_hat 0.5: the weight's midpoint, w = 1/2
    assert w == 0.5
    assert metrics.bounded_transparency(0.6, 0.2, 0.5, True) == pytest.approx(0.4)  # inside [0, 1]: T itself
    assert metrics.bounded_transparency(1.8, -2.0, 0.5, True) == pytest.approx(0.5)  # (1 + 0) / 2
    assert metrics.bounded_transparency(-3.0, -1.0, 0.5, True) == 0.0  # a success below every reference: 0
    assert metrics.bounded_transparency(3.0, 1.5, 0.5, False) == 0.0  # a failed detour: the scene's worst
    assert metrics.bounded_transparency(-3.0, -1.0, 0.5, False) == 0.0  # a failure never below the worst either
    out = metrics.bounded_transparency(np.array([0.6, 0.6]), np.array([0.2, 0.2]), 0.5, np.array([True, False]))
    assert out.tolist() == [pytest.approx(0.4), 0.0]
    failed = _record("ld_paper", 0, _bent(0.0), success=False, t=2.0)
    assert record_value(failed, "transparency_bounded") == 0.0 and record_value(failed, "transparency_fa") == 0.0


def test_rescoring_with_our_range_reproduces_the_stored_t_and_another_range_moves_w():
    r = _record("dp", 0, _bent(0.3))
    ours = sensitivity.rescore(r, sensitivity.box_range("navigation"))
    assert ours["transparency"] == r.metrics["transparency"]
    lo, hi = 0.15, math.hypot(2.5, 3.0)  # Navigation: minimum separation, diagonal of the 2.5 m × 3 m goal box
    assert ours["j_hat"] == pytest.approx((0.4 - lo) / (hi - lo))
    assert ours["w"] == pytest.approx(1 / (1 + math.exp(-2.5 * ((0.4 - lo) / (hi - lo) - 0.5))))  # 0.2528
    mid = sensitivity.rescore(r, (0.2, 0.6))  # j = 0.4 is the middle of this range: w = 1/2
    assert (mid["j_hat"], mid["w"]) == pytest.approx((0.5, 0.5))
    assert mid["transparency"] == pytest.approx(0.5 * (r.metrics["d_hat"] + r.metrics["e_hat"]))
    assert sensitivity.rescore(r, (0.5, 0.9))["w"] == pytest.approx(sensitivity.W_MIN)  # clipped at ĵ = 0


def test_sensitivity_shows_both_ranges_side_by_side():
    records = []
    for i, k in enumerate((0.1, 0.2, 0.3, 0.4)):
        records += [_record("scdp", i, _bent(-k)), _record("dp", i, _bent(0.05))]
    result = sensitivity.sensitivity(records, {"navigation": (0.2, 0.6)}, {"navigation": "test range"},
                                     scene_sets=("ambiguous",))
    row = next(r for r in result["rows"] if r["metric"] == "transparency")
    by = {(r.method, r.scene_index): r.metrics for r in records}
    ours = np.mean([by["scdp", i]["transparency"] - by["dp", i]["transparency"] for i in range(4)])
    half = np.mean([0.5 * (by["scdp", i]["d_hat"] + by["scdp", i]["e_hat"] - by["dp", i]["d_hat"] - by["dp", i]["e_hat"])
                    for i in range(4)])
    assert row[sensitivity.OURS][0] == pytest.approx(ours) and row[sensitivity.ALTERNATIVE][0] == pytest.approx(half)
    assert row[sensitivity.OURS][0] != pytest.approx(row[sensitivity.ALTERNATIVE][0])
    (weights,) = result["weights"]
    assert weights[sensitivity.ALTERNATIVE]["mean"] == pytest.approx(0.5) and weights[sensitivity.OURS]["scenes"] == 4
    assert result["rescore_error"] == 0.0 and result["ranges"]["navigation"]["source"] == "test range"
    text = sensitivity.sensitivity_markdown(result)
    assert "| navigation | ambiguous | scdp − dp | T |" in text and "test range" in text


def test_the_papers_tables_imply_weights_outside_the_sigmoid():
    rows = {(p["task"], p["method"], p["scene_set"]): p for p in sensitivity.paper_implied_weights()}
    clear = rows["block_reach", "scdp", "non_ambiguous"]
    assert clear["w"] == pytest.approx((0.74 - 0.42) / (0.80 - 0.42))  # 0.842
    # lowest w: T low, D̂ and Ê high (w falls in both when T < Ê): 0.31 / 0.38 = 0.816 > 0.777
    assert clear["lo"] == pytest.approx((0.735 - 0.425) / (0.805 - 0.425)) and clear["fits"] is False
    assert rows["navigation", "ld", "ambiguous"]["fits"] is True
    assert sensitivity.implied_weight(0.5, 0.30, 0.305)["w"] is None  # Ê − D̂ within rounding of 0
    assert sum(p["fits"] is False for p in rows.values()) == 5


def test_every_method_claims_cover_every_method_and_name_them():
    stat = lambda v: {"mean": v, "std": 0.0}  # noqa: E731
    entry = lambda t, s=1.0: {"transparency": stat(t), "d_hat": stat(0.5), "e_hat": stat(0.5), "success": stat(s)}  # noqa: E731
    sets = {m: entry(0.5) for m in ("dp", "ld", "scdp", "scdp_blend")}
    summ = {"navigation": {"ambiguous": {**sets, "ld_paper": entry(0.8, 0.77), "dataset": entry(0.4, 0.5)},
                           "non_ambiguous": dict(sets)}}
    (success,) = [c for c in claims.claims(summ) if c["claim"].startswith("success")]
    assert success["claim"] == ("success >= 0.98 for every method (dp, ld, scdp, ld_paper, scdp_blend; Dataset row excluded) "
                                "on ambiguous, non_ambiguous")
    assert not success["holds"] and success["numbers"]["ambiguous/ld_paper"] == 0.77
    assert "ambiguous/dataset" not in success["numbers"]  # the Dataset row is named, not judged
    best = next(c for c in claims.claims(summ) if c["claim"].startswith("SCDP has the best"))
    assert "of dp, ld, scdp" in best["claim"]
    summ["navigation"]["ambiguous"]["ld_paper"] = entry(0.8)
    assert next(c for c in claims.claims(summ) if c["claim"].startswith("success"))["holds"]
    assert targets.success_methods(["scdp_legible", "dataset", "ld_paper", "dp"]) == ["dp", "ld_paper", "scdp_legible"]


def test_the_report_rebuilds_from_results_json_alone(tmp_path):
    from scdp.pipeline.report import rebuild_report

    far = [[1.0, 1.0], [1.0, -1.0]]  # a clear scene: goals 2 m apart
    records = []
    for s, goals in (("ambiguous", GOALS), ("non_ambiguous", far)):
        for i in range(3):
            records += [_record("scdp", i, _bent(-0.1 * (i + 1)), scene_set=s, goals=goals),
                        _record("dp", i, _bent(0.05), scene_set=s, goals=goals),
                        _record("ld", i, _bent(0.1), scene_set=s, goals=goals),
                        _record("dataset", i, _bent(0.0), scene_set=s, goals=goals),
                        _record("ld_paper", i, _bent(0.8), scene_set=s, goals=goals, success=i > 0,
                                t=2.5 if i == 0 else None)]  # its failure scores raw T 2.5
    results = tmp_path / "results.json"
    results.write_text(json.dumps({"command": "test", "preset": "tiny", "overrides": [], "protocols": ["random"],
                                   "wall_seconds": 1.0, "compute_minutes": {"random": 0.1, "per_layout": 0.0},
                                   "trajectories": [{**r.to_dict(), "protocol": "random"} for r in records]}))
    rebuild_report(results, tmp_path / "a")
    rebuild_report(results, tmp_path / "b")
    text = (tmp_path / "a" / "report.md").read_text()
    assert text == (tmp_path / "b" / "report.md").read_text()  # deterministic
    assert "## Metric sensitivity" in text and "evaluation scenes (training dataset not present)" in text
    assert "T_fa (failure-aware T): a successful run scores its T; a failed run scores min(T, 0)" in text
    assert "0.67 [" in text  # ld_paper's success rate with its interval
    saved = json.loads((tmp_path / "a" / "claims.json").read_text())
    assert saved["metric_sensitivity"]["ranges"]["navigation"][sensitivity.ALTERNATIVE] == [
        pytest.approx(0.4), pytest.approx(2.0)]
    assert any("ld_paper" in c["claim"] and not c["holds"] for c in saved["claims"])
    diff = {(r["scene_set"], r["metric"]): r["mean"] for r in saved["paired_differences"] if r["b"] == "ld_paper"}
    for s in ("ambiguous", "non_ambiguous"):  # the failure's 2.5 becomes 0: scdp − ld_paper rises by 2.5 / 3
        assert diff[s, "transparency_fa"] - diff[s, "transparency"] == pytest.approx(2.5 / 3)
    assert tables.ordered_methods({"ld_paper", "dataset", "dp"}) == ["dp", "dataset", "ld_paper"]


def test_the_alternative_range_comes_from_the_training_dataset_when_present(tmp_path):
    from scdp.data.dataset import DemoDataset
    from scdp.pipeline.report import sensitivity_ranges

    def episode(goals, target, steps=3):
        return {"state": np.zeros((steps, 3)), "action": np.zeros((steps, 3)), "goals": np.asarray(goals), "target": target}

    demos = DemoDataset.from_episodes("navigation", [episode([[1, 0], [1, 0.5]], 0), episode([[2, 0], [2, 2]], 1, 4),
                                                     episode([[1, 1], [3, 3]], 0)])  # j = 0.5, 2, sqrt(8)
    demos.save(tmp_path / "navigation" / "demos.zarr")
    records = [_record("dp", 0, _bent(0.0))]
    ranges, sources = sensitivity_ranges(tmp_path, records)
    assert sources == {"navigation": "training dataset"}
    assert ranges["navigation"] == pytest.approx((0.5, math.sqrt(8)))
    ranges, sources = sensitivity_ranges(tmp_path / "elsewhere", records)
    assert sources["navigation"].startswith("evaluation scenes") and ranges["navigation"] == pytest.approx((0.4, 0.4))
