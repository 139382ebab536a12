"""The real-time gate's verdict (scdp.evaluation.noninferiority) on the committed run's records.

The default is the committed cpu run's Navigation records (dp and the SCDP family, 100 + 100
scenes); a candidate is built from them by hand, so what it loses is known exactly.
"""

from dataclasses import replace
from pathlib import Path

import pytest

from scdp.evaluation.noninferiority import BOUNDS, MIN_SUCCESS, READ, failed, verdict
from scdp.evaluation.records import FAILURE_AWARE, load_records
from scdp.keys import AMBIGUOUS, CLEAR

RUN = Path(__file__).resolve().parents[1] / "results" / "cpu" / "results.json"  # committed (trajectories.json is not)
METHODS = ("dp", "scdp", "scdp_legible", "scdp_efficient", "scdp_blend")


@pytest.fixture(scope="module")
def default():
    return [r for r in load_records(RUN) if r.task == "navigation" and r.method in METHODS
            and r.scene_set in (AMBIGUOUS, CLEAR) and r.protocol in (None, "random")]


def shifted(records, metric: str, by: float, methods=METHODS):
    """The records with ``metric`` moved by ``by`` for ``methods`` (T moves T_fa alike on successes)."""
    return [replace(r, metrics={**r.metrics, metric: r.metrics[metric] + by}) if r.method in methods else r
            for r in records]


def failing(result) -> set:
    return {(c.get("measure", c["check"]), c.get("method"), c.get("scene_set"))
            for t in result["tasks"].values() for c in t["checks"] if not c["holds"]}


def test_a_planner_equal_to_the_default_passes(default):
    result = verdict(default, default)
    assert result["passes"], failed(result)


def test_a_planner_that_loses_a_tenth_of_d_hat_fails_on_d_hat_and_the_forced_gap(default):
    lossy = shifted(default, "d_hat", -0.1, ("scdp", "scdp_legible"))
    result = verdict(default, lossy)
    assert not result["passes"]
    misses = failing(result)
    assert ("d_hat", "scdp", AMBIGUOUS) in misses and ("d_hat", "scdp_legible", AMBIGUOUS) in misses
    assert ("forced_gap", None, AMBIGUOUS) in misses  # the legible style lost 0.1 of its gap
    assert any("d_hat scdp ambiguous: lower bound -0.100" in line for line in failed(result))


def test_the_transparency_margin_is_the_one_written_in_the_bounds(default):
    margin = next(b.margin for b in BOUNDS if b.measure == FAILURE_AWARE)
    # a constant shift: every bootstrap mean equals it, so the one-sided bound is the shift itself
    assert verdict(default, shifted(default, "transparency", margin + 0.005))["passes"]
    assert not verdict(default, shifted(default, "transparency", margin - 0.005))["passes"]


def test_a_failed_run_or_a_missing_method_fails_the_gate(default):
    crashed = [replace(r, success=False) if r.method == "dp" and r.scene_index == 0 else r for r in default]
    assert 1 - 1 / 100 >= MIN_SUCCESS  # one failure in 100 scenes is allowed, two are not
    assert verdict(default, crashed)["passes"]
    crashed = [replace(r, success=False) if r.method == "dp" and r.scene_index in (0, 1) else r for r in default]
    assert ("success", "dp", AMBIGUOUS) in failing(verdict(default, crashed))
    result = verdict(default, [r for r in default if r.method != "scdp_efficient"])
    assert ("forced_gap", None, None) in failing(result) and ("success", "scdp_efficient", CLEAR) in failing(result)


def test_the_observer_reading_is_one_of_the_bounds(default):
    """A candidate whose legible paths are the efficient style's reads worse at half the motion."""
    efficient = {(r.scene_set, r.scene_index): r for r in default if r.method == "scdp_efficient"}
    swapped = [replace(r, path=efficient[r.scene_set, r.scene_index].path) if r.method == "scdp_legible" else r
               for r in default]
    result = verdict(default, swapped)
    assert (READ, "scdp_legible", AMBIGUOUS) in failing(result)
    assert (READ, "scdp", AMBIGUOUS) not in failing(result)
