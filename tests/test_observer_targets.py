"""The observer-grounded targets (scdp.evaluation.observer_targets), on Navigation records built by hand.

Two goals 1 m apart, 2 m ahead; the target is the upper one. A path that heads straight for it is
read right by the path-length observer at half the motion; one that first heads for the lower goal
is read wrong there (the observer's own hand tests are in tests/test_observers.py).
"""

import subprocess
import sys
from pathlib import Path

import pytest

from scdp.evaluation.observer_targets import observer_targets, observer_targets_markdown
from scdp.evaluation.records import TrajectoryRecord, load_records
from scdp.io import read_json, write_json
from scdp.keys import AMBIGUOUS, CLEAR

GOALS = [[2.0, 0.5], [2.0, -0.5]]
RIGHT = [[0.0, 0.0], [1.0, 0.25], [2.0, 0.5]]
WRONG = [[0.0, 0.0], [1.0, -0.45], [2.0, 0.5]]
SCENES = 8
LEGIBLE_E, EFFICIENT_E = 0.3, 0.9


def _record(method, scene_set, i, path, e_hat=0.5, success=True):
    return TrajectoryRecord(task="navigation", scene_set=scene_set, method=method, goals=GOALS, target=0, path=path,
                            success=success, bounds={}, j_hat=0.1, metrics={"d_hat": 0.5, "e_hat": e_hat, "transparency": 0.5}, beta=4.0,
                            scene_index=i)


def _records(reads: dict, clear_e: dict, failed: tuple = (), scenes: int = SCENES):
    """``reads[method]``: read right in ambiguous scenes (True, False, or the set of scenes where it is);
    ``clear_e[method]``: its Ê in clear scenes."""
    def right(m, i):
        return i in reads[m] if isinstance(reads[m], (set, frozenset)) else reads[m]

    out = []
    for i in range(scenes):
        out += [_record(m, AMBIGUOUS, i, RIGHT if right(m, i) else WRONG, success=(m, i) not in failed) for m in reads]
        out += [_record(m, CLEAR, i, RIGHT, e_hat=e, success=(m, i) not in failed) for m, e in clear_e.items()]
    return out


ADAPTIVE = dict(reads={"scdp_legible": True, "scdp_efficient": False, "scdp": True, "dp": False, "ld": True},
                clear_e={"scdp_legible": LEGIBLE_E, "scdp_efficient": EFFICIENT_E, "scdp": EFFICIENT_E, "dp": EFFICIENT_E,
                         "ld": LEGIBLE_E})


def test_an_adaptive_planner_that_observers_read_meets_every_target():
    style, against_dp, efficient_share, legible_share, success = observer_targets(_records(**ADAPTIVE))
    assert all(r["holds"] for r in (style, against_dp, efficient_share, legible_share, success))
    assert style["numbers"]["mean"] == pytest.approx(1.0) and style["numbers"]["n"] == SCENES
    assert efficient_share["numbers"]["share"] == pytest.approx(1.0) and legible_share["numbers"]["share"] == pytest.approx(1.0)
    beside = against_dp["beside"]
    assert beside["scdp - ld"]["mean"] == pytest.approx(0.0)  # LD reads right too
    assert beside["viewpoint"]["mean"] == pytest.approx(1.0)  # Navigation is watched from above: the same reading


def test_a_gain_above_zero_but_under_the_margin_is_missed():
    setup = {**ADAPTIVE, "reads": {**ADAPTIVE["reads"], "scdp_efficient": set(range(8, 100))}}  # wrong in 8 of 100
    style = observer_targets(_records(**setup, scenes=100))[0]
    assert style["numbers"]["mean"] == pytest.approx(0.08) and style["numbers"]["lo"] > 0
    assert not style["holds"]


def test_a_legible_style_that_reads_no_better_misses_the_style_effect_and_the_legible_share():
    setup = {**ADAPTIVE, "reads": {**ADAPTIVE["reads"], "scdp_efficient": True}}
    rows = observer_targets(_records(**setup))
    missed = {r["target"] for r in rows if not r["holds"]}
    assert missed == {"forced legible - forced efficient, path-length observer correct at 50 % >= +0.10",
                      "scdp keeps >= 80 % of the legible style's path-length observer gain (ambiguous)"}
    share = next(r for r in rows if "legible style's" in r["target"])["numbers"]
    assert not share["styles_differ"]


def test_a_full_share_of_a_gap_that_may_be_zero_says_nothing():
    setup = {**ADAPTIVE, "reads": {**ADAPTIVE["reads"], "scdp_efficient": set(range(2, SCENES))}}  # differ in 2 of 8
    legible_share = observer_targets(_records(**setup))[3]
    assert legible_share["numbers"]["share"] == pytest.approx(1.0) and legible_share["numbers"]["style_gap_lo"] <= 0
    assert not legible_share["holds"]


def test_an_always_legible_planner_misses_the_efficient_share():
    setup = {**ADAPTIVE, "clear_e": {**ADAPTIVE["clear_e"], "scdp": LEGIBLE_E}}
    row = next(r for r in observer_targets(_records(**setup)) if "efficient style's" in r["target"])
    assert not row["holds"] and row["numbers"]["share"] == pytest.approx(0.0)
    assert row["beside"]["ld"]["share"] == pytest.approx(0.0)


def test_one_failure_in_eight_misses_success_and_a_missing_method_is_named():
    row = next(r for r in observer_targets(_records(**ADAPTIVE, failed=(("dp", 3),))) if r["target"].startswith("success"))
    assert not row["holds"] and row["numbers"]["dp ambiguous"] == pytest.approx(7 / 8)
    reads = {k: v for k, v in ADAPTIVE["reads"].items() if k != "dp"}
    rows = observer_targets(_records(reads, {k: v for k, v in ADAPTIVE["clear_e"].items() if k != "dp"}))
    against_dp = next(r for r in rows if r["target"].startswith("scdp - dp"))
    assert not against_dp["holds"] and against_dp["numbers"] == {"missing": ["dp"]}
    assert "did not run: ['dp']" in observer_targets_markdown(rows)


def test_the_table_says_missed_in_bold_and_gives_each_interval():
    setup = {**ADAPTIVE, "reads": {**ADAPTIVE["reads"], "scdp": False}}
    table = observer_targets_markdown(observer_targets(_records(**setup)))
    line = next(x for x in table.splitlines() if "scdp - dp" in x)
    assert "**missed**" in line and "+0.000 [+0.000, +0.000]" in line


def test_pooling_two_seeds_keeps_every_path_and_the_commit(tmp_path):
    # two "seeds" of hand-built records: in the second the efficient style reads right too
    seeds = [_records(**ADAPTIVE), _records(**{**ADAPTIVE, "reads": {**ADAPTIVE["reads"], "scdp_efficient": True}})]
    for k, records in enumerate(seeds):
        write_json(tmp_path / f"in_{k}.json.gz", {"trajectories": [r.to_dict() for r in records]}, compact=True)
    out = tmp_path / "pooled"
    subprocess.run([sys.executable, "benchmarks/pool_seeds.py", "--runs", str(tmp_path / "in_0.json.gz"), str(tmp_path / "in_1.json.gz"),
                    "--seeds", "0", "1", "--out", str(out), "--targets", "observers", "--keep-paths", "--commit", "abc123"],
                   check=True, capture_output=True, cwd=Path(__file__).parents[1])
    kept = load_records(out / "seed_1.json.gz")
    assert [r.path for r in kept] == [r.path for r in seeds[1]] and read_json(out / "seed_1.json.gz")["commit"] == "abc123"
    pooled = read_json(out / "pooled.json")
    style = pooled["targets"][0]
    assert style["per_seed"] == {"0": 1.0, "1": 0.0} and style["per_seed_holds"] == [True, False]
    assert style["numbers"]["mean"] == pytest.approx(0.5) and style["numbers"]["scenes"] == SCENES  # seeds nested in scenes
    assert {r["planner"] for r in pooled["adaptivity"]} >= {"scdp", "dp", "ld"} and "abc123" in (out / "pooled.md").read_text()
