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


def test_every_observer_is_reported_each_under_its_three_temperatures(measured):
    report = observation.observer_report(measured.records)
    assert report["path_length"]["summary"]["beta"] == [4.0] and report["demonstration"]["summary"]["beta"] == [20.0]
    assert report["demonstration"]["summary"]["observer"].startswith("demonstration observer")
    demo = report["demonstration"]["summary"]["tasks"]["navigation"]["ambiguous"]
    assert demo["scdp"]["curve"][-1] == 1.0 and demo["dp"]["curve"][-1] == 0.5  # the run to the distractor is never right
    assert demo["scdp"]["curve"][0] == 0.0  # every demonstration starts at the start: a tie
    betas = {(r["observer"], r["beta"]) for r in report["temperatures"]}
    assert betas == ({(o, b) for o in ("path_length", "viewpoint") for b in (2.0, 4.0, 8.0)}
                     | {("demonstration", b) for b in (10.0, 20.0, 40.0)})
    row = next(r for r in report["temperatures"] if r["observer"] == "demonstration" and r["beta"] == 20.0 and r["method"] == "dp")
    assert row["correct_at_50"] == demo["dp"]["correct_at_50"] and row["never_confident"] == demo["dp"]["never_confident"]
    # Navigation is watched from above: the viewpoint observer reads what the path-length observer reads
    assert report["viewpoint"]["summary"]["tasks"] == report["path_length"]["summary"]["tasks"]
    text = observation.observer_report_markdown(report, {"path_length": "a.png", "demonstration": "b.png", "viewpoint": "c.png"})
    assert "β = 20" in text and "β = 4" in text and "demonstration β=40" in text and "![" in text


def _arm(goals, target, path):
    return TrajectoryRecord(task="block_reach", scene_set="ambiguous", method="dp", goals=goals, target=target,
                            path=path, success=True, bounds={}, j_hat=0.0, metrics={}, beta=4.0)


def test_the_viewpoint_observer_sees_the_arm_from_across_the_table():
    """The Block Reach viewer stands on the robot's x axis (1.7 m out, 1.05 m up) looking back at it.
    Two blocks one behind the other on a line of sight project to one image point: the path-length
    observer (task space) tells them apart, the viewpoint observer cannot. Two blocks side by side
    (y = +-0.15) are as distinct seen from there as from above."""
    from scdp.perception import viewer_camera
    from scdp.tasks import BLOCK_REACH

    eye = np.array(BLOCK_REACH.viewer_eye)
    near = np.array([0.6, 0.0, 0.1])
    far = eye + 1.3 * (near - eye)  # on the ray from the eye through the near block, farther away
    start = np.array([0.3, 0.0, 0.5])
    camera = viewer_camera(BLOCK_REACH)
    pixels = camera.project(np.array([near, far]))[0]
    assert np.allclose(pixels[0], pixels[1], atol=1e-6)  # one image point
    path = np.linspace(start, near, 60).tolist()
    hidden = _arm([near.tolist(), far.tolist()], 0, path)
    view = observation.record_measures(hidden, belief=observation.Belief("viewpoint"))
    plain = observation.record_measures(hidden, belief=observation.Belief("path_length"))
    assert not any(view["correct"])  # a tie all along: never right, never confident
    assert np.isnan(view["time_to_confidence"]) and view["capped"]
    assert plain["correct"][10] and plain["correct"][-1]  # in task space the far block is plainly elsewhere
    side = [[0.6, 0.15, 0.1], [0.6, -0.15, 0.1]]
    beside = observation.record_measures(_arm(side, 0, np.linspace(start, side[0], 60).tolist()),
                                         belief=observation.Belief("viewpoint"))
    assert all(beside["correct"][1:]) and not beside["capped"]
