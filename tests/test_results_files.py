"""Committed results recompute from what they store, and old result files still load.

* every table, claim and the report in ``results/cpu`` is rebuilt from ``results/cpu/results.json``
  (and the committed demos, for the training dataset's ranges) and must come out the same: every word
  identical, every number the same to float rounding (``helpers.floats``: the committed files were
  written on another processor, whose SIMD kernels add in another order);
* result files written before layouts had their name still load in the report code.
"""

import json
import re
import shutil
from pathlib import Path

from helpers.floats import close, file_mismatches, mismatches
from scdp.evaluation import claims, tables
from scdp.evaluation.records import load_records
from scdp.pipeline.report import rebuild_report

CPU = Path(__file__).parents[1] / "results" / "cpu"
REBUILT = ("table1.md", "table1.tex", "table2.md", "table2.tex", "table1_dataset.md", "table1_dataset.tex", "table2_dataset.md",
           "table2_dataset.tex", "claims.json", "report.md")


def test_the_committed_tables_claims_and_report_recompute_from_results_json(tmp_path):
    """Nothing in them is typed by hand or left over from an older run: rebuilt from the records alone,
    each file is the same (the bootstrap is seeded), to float rounding across processors."""
    for task in ("navigation", "block_reach"):
        shutil.copytree(CPU / task / "demos.zarr", tmp_path / task / "demos.zarr")
    rebuild_report(CPU / "results.json", tmp_path)
    for name in REBUILT:
        wrong = file_mismatches((tmp_path / name).read_text(), (CPU / name).read_text(), name)
        assert not wrong, f"results/cpu/{name} does not recompute: {wrong[:5]}"


def test_results_written_before_layouts_were_named_still_load(tmp_path):
    """An old-schema file: ``config_k`` scene sets and the ``per_config`` protocol."""
    old = []
    methods = ("dp", "ld", "scdp", "dataset")
    rows = ([("random", "ambiguous", m, 0.5) for m in methods] + [("random", "non_ambiguous", m, 0.6) for m in methods]
            + [("per_config", f"config_{k}", m, 0.4) for k in (1, 4) for m in methods])
    for protocol, scene_set, method, t in rows:
        old.append({"task": "navigation", "scene_set": scene_set, "method": method, "goals": [[2, 0.2], [2, -0.2]],
                    "target": 0, "path": [[0, 0], [2, 0.2]], "success": True,
                    "bounds": {"d_min": 0, "d_max": 1, "e_min": 0, "e_max": 1}, "j_hat": 0.1,
                    "metrics": {"detachment": 1, "efficiency": 1, "d_hat": t, "e_hat": t, "transparency": t, "legibility": 0.5},
                    "beta": 4.0, "styles": [], "seconds": 0.1, "protocol": protocol})
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"preset": "cpu", "protocols": ["random", "per_config"], "trajectories": old}))
    records = load_records(path)
    assert {r.protocol for r in records} == {"random", "per_layout"}
    assert {r.scene_set for r in records if r.protocol == "per_layout"} == {"layout_1", "layout_4"}
    by_protocol = {p: tables.summaries([r for r in records if r.protocol == p]) for p in ("random", "per_layout")}
    assert by_protocol["per_layout"]["navigation"]["layouts_ambiguous"]["scdp"]["transparency"]["mean"] == 0.4
    assert "0.50 ± 0.00" in tables.table1(by_protocol["random"])
    assert len(claims.claims(by_protocol["per_layout"], tables.LAYOUT_GROUPS, "per_layout")) == 5
    assert "per-layout models" in tables.table3(by_protocol)


def test_the_committed_cpu_results_load():
    path = Path(__file__).parents[1] / "results" / "cpu" / "results.json"
    records = load_records(path)
    summary = tables.summaries([r for r in records if r.protocol == "random"])
    assert set(summary) == {"navigation", "block_reach"} and "layout_1" in summary["navigation"]
    assert "Ours (SCDP)" in tables.table1(summary)


def test_with_two_goals_a_sample_of_the_committed_metrics_recomputes_exactly():
    """The N-goal code path leaves two-goal numbers as they were: every 40th committed record of the
    random sets is rescored from its path (metrics and the scene's reference bounds, to float rounding
    across processors: ``helpers.floats``), and the evaluation scenes drawn today are the scenes it was
    rolled out in."""
    import numpy as np

    from scdp.evaluation.protocol import scene_sets
    from scdp.evaluation.records import rescore, scene_bounds
    from scdp.tasks import get_task

    records = [r for r in load_records(CPU / "results.json") if r.protocol == "random" and not r.scene_set.startswith("layout_")]
    sample = records[::40]
    assert len(sample) >= 50
    sets = {task: scene_sets(get_task(task), 100, 1) for task in ("navigation", "block_reach")}
    for r in sample:
        task = get_task(r.task)
        assert not mismatches(rescore(task, r), r.metrics)
        assert not mismatches(scene_bounds(task, r.goals, r.target).to_dict(), r.bounds)
        goals, target = sets[r.task][r.scene_set][r.scene_index]
        assert np.allclose(goals, r.goals, atol=1e-12) and target == r.target


def test_the_goal_count_table_recomputes_from_its_records():
    """results/goals: every N's forced-style gap and each method's means come back from the committed records
    (the whole table, observers included, is rebuilt by ``benchmarks/goal_count.py --report-only``)."""
    from scdp.evaluation.records import TrajectoryRecord, summarize
    from scdp.evaluation.statistics import compare

    goals = Path(__file__).parents[1] / "results" / "goals"
    summary = json.loads((goals / "goal_count.json").read_text())
    for task in ("navigation", "block_reach"):
        for n in ("2", "3", "4", "5"):
            data = json.loads((goals / f"records_{task}_{n}.json").read_text())
            records = [TrajectoryRecord.from_dict(r) for r in data["records"]]
            assert {len(r.goals) for r in records} == {int(n)}
            ambiguous = [r for r in records if r.scene_set == "ambiguous"]
            stored = summary["tasks"][task][n]["ambiguous"]
            gap = json.loads(json.dumps(compare(ambiguous, "scdp_legible", "scdp_efficient", "d_hat").row()))
            assert not mismatches(gap, stored["forced_styles_d_hat"])
            for method in ("dp", "ld", "scdp", "scdp_blend"):
                s = summarize([r for r in ambiguous if r.method == method])
                assert close(s["d_hat"]["mean"], stored["methods"][method]["d_hat"])
                assert close(s["success"]["mean"], stored["methods"][method]["success"])


def test_the_readme_s_compute_minutes_are_the_committed_report_s():
    """The README quotes the committed run's compute time; it must be the one results.json records
    (the sum over its stages, as report.md prints it), not a number typed in by hand."""
    readme = (Path(__file__).parents[1] / "README.md").read_text()
    quoted = re.search(r"The committed run took ([\d.]+) min of compute", readme)
    assert quoted, "the README no longer quotes the committed run's compute minutes"
    meta = json.loads((Path(__file__).parents[1] / "results" / "cpu" / "results.json").read_text())
    total = sum(meta["compute_minutes"].values())
    assert float(quoted.group(1)) == round(total, 1)
    report = (Path(__file__).parents[1] / "results" / "cpu" / "report.md").read_text()
    assert f"({quoted.group(1)} min)" in report
