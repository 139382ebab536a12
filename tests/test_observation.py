"""The report's observer section (scdp.evaluation.observation) on records built by hand."""

import numpy as np
import pytest

from scdp.evaluation import observation
from scdp.evaluation.records import TrajectoryRecord

GOALS = [[2.0, 1.0], [2.0, -1.0]]  # far apart: a straight path to either is read early and surely


def line(to, n=60):
    return np.linspace([0.0, 0.0], to, n).tolist()


def record(method, index, path):
    return TrajectoryRecord(task="navigation", scene_set="ambiguous", method=method, goals=GOALS, target=0, path=path,
                            success=True, bounds={"d_min": 0, "d_max": 1, "e_min": 0, "e_max": 1}, j_hat=0.5,
                            metrics={}, beta=4.0, scene_index=index)


@pytest.fixture(scope="module")
def measured():
    # scene 0: scdp drives to the target, dp to the distractor; scene 1: both drive to the target
    records = [record("scdp", 0, line(GOALS[0])), record("dp", 0, line(GOALS[1])),
               record("scdp", 1, line(GOALS[0])), record("dp", 1, line(GOALS[0]))]
    return observation.Measured(records)


def test_shares_count_runs_and_never_confident_runs_are_kept_apart(measured):
    summary = observation.observer_summary(measured)
    scdp, dp = (summary["tasks"]["navigation"]["ambiguous"][m] for m in ("scdp", "dp"))
    assert scdp["runs"] == dp["runs"] == 2
    assert scdp["never_confident"] == 0.0 and dp["never_confident"] == 0.5  # the run to the distractor
    # the median is over confident runs only: dp's is its one run to the target, the same path as scdp's
    assert dp["time_to_confidence_median"] == scdp["time_to_confidence_median"]
    assert 0.0 < scdp["time_to_confidence_median"] < 1.0
    assert [scdp[f"correct_at_{p}"] for p in (25, 50, 75)] == [1.0, 1.0, 1.0]
    assert [dp[f"correct_at_{p}"] for p in (25, 50, 75)] == [0.5, 0.5, 0.5]
    assert scdp["curve"][0] == dp["curve"][0] == 0.0  # at the start every goal ties
    assert len(scdp["curve"]) == len(summary["curve_fractions"]) == 21 and summary["beta"] == [4.0]


def test_paired_differences_use_the_same_scenes_and_leave_out_pairs_without_a_value(measured):
    rows = {r["metric"]: r for r in observation.observer_differences(measured)}
    assert rows["correct_at_50"]["mean"] == 0.5 and rows["correct_at_50"]["n"] == 2  # (1 - 0 + 1 - 1) / 2
    assert rows["never_confident"]["mean"] == -0.5
    assert rows["time_to_confidence"]["n"] == 1 and rows["time_to_confidence"]["mean"] == 0.0  # scene 1 only
    assert all(r["a"] == "scdp" and r["b"] == "dp" for r in rows.values())


def test_the_report_section_names_the_observer_and_its_beta(measured):
    text = observation.observer_markdown(observation.observer_summary(measured), observation.observer_differences(measured))
    assert "path-length observer" in text and "β = 4" in text
    assert "| scdp | 2 | 0.000 |" in text and "| dp | 2 | 0.500 |" in text
    row = next(line for line in text.splitlines() if line.startswith("| navigation | ambiguous | scdp | "))
    assert row.count("+0.500*") + row.count("+0.500 ") == 3 and "-0.500" in row and "(n 1)" in row


def test_a_scene_whose_goals_are_too_close_caps_the_observer_below_confidence():
    close = [[2.0, 0.05], [2.0, -0.05]]  # even on g*, P(g*) = 1 / (1 + e^(-4 * 0.1 / 2.0006)) ~ 0.55 < 0.8
    near = TrajectoryRecord(task="navigation", scene_set="ambiguous", method="dp", goals=close, target=0,
                            path=line(close[0]), success=True, bounds={}, j_hat=0.0, metrics={}, beta=4.0)
    far = record("dp", 1, line(GOALS[0]))
    measures = [observation.record_measures(r) for r in (near, far)]
    assert [m["capped"] for m in measures] == [True, False]
    assert np.isnan(measures[0]["time_to_confidence"]) and not np.isnan(measures[1]["time_to_confidence"])


def test_both_observers_are_reported_each_under_its_three_temperatures(measured):
    report = observation.observer_report(measured.records)
    assert report["path_length"]["summary"]["beta"] == [4.0] and report["demonstration"]["summary"]["beta"] == [20.0]
    assert report["demonstration"]["summary"]["observer"].startswith("demonstration observer")
    demo = report["demonstration"]["summary"]["tasks"]["navigation"]["ambiguous"]
    assert demo["scdp"]["curve"][-1] == 1.0 and demo["dp"]["curve"][-1] == 0.5  # the run to the distractor is never right
    assert demo["scdp"]["curve"][0] == 0.0  # every demonstration starts at the start: a tie
    betas = {(r["observer"], r["beta"]) for r in report["temperatures"]}
    assert betas == {("path_length", b) for b in (2.0, 4.0, 8.0)} | {("demonstration", b) for b in (10.0, 20.0, 40.0)}
    row = next(r for r in report["temperatures"] if r["observer"] == "demonstration" and r["beta"] == 20.0 and r["method"] == "dp")
    assert row["correct_at_50"] == demo["dp"]["correct_at_50"] and row["never_confident"] == demo["dp"]["never_confident"]
    text = observation.observer_report_markdown(report, {"path_length": "a.png", "demonstration": "b.png"})
    assert "β = 20" in text and "β = 4" in text and "demonstration β=40" in text and "![" in text
