"""The reproduction pipeline's bookkeeping: the stage plan, stale outputs, and the paper's
claims judged on each protocol."""


import pytest

from scdp.evaluation import claims, tables
from scdp.pipeline.plan import plan_stages
from scdp.pipeline.stages import Stage
from scdp.presets import PRESETS
from scdp.tasks import get_task


def test_stage_plan_per_protocol(tmp_path):
    task, tiny = get_task("navigation"), PRESETS["tiny"]
    names = [s.name for s in plan_stages(task, tiny, tmp_path, "both", [2, 5])]
    assert names[:2] == ["ambiguity", "encoder"] and names[-1] == "per_layout/evaluate"
    assert {"demos", "base", "style_legible", "style_efficient", "ld", "evaluate"} <= set(names)
    for k in (2, 5):  # tiny evaluates scdp_paper, so its paper-design predictors are trained too
        assert [n for n in names if n.startswith(f"per_layout/layout_{k}/")] == [
            f"per_layout/layout_{k}/{s}" for s in ("demos", "base", "style_legible", "style_efficient", "ld",
                                                  "style_paper_legible", "style_paper_efficient")]
    assert not any(n.startswith("per_layout/layout_1/") for n in names)

    stages = plan_stages(task, tiny, tmp_path, "per_layout", [2])
    assert "evaluate" not in [s.name for s in stages] and "base" not in [s.name for s in stages]
    layout_set = next(s.ms for s in stages if s.name == "per_layout/layout_2/base")
    assert layout_set.folder == tmp_path / "per_layout" / "layout_2" and layout_set.scenes == "layout_2"
    assert layout_set.encoder_dir == tmp_path / "checkpoints" / "encoder"  # the task's shared encoder
    assert layout_set.preset == tiny.for_layout(2)
    assert not any(s.name.startswith("per_layout") for s in plan_stages(task, tiny, tmp_path, "random"))


def _stat(mean):
    return {"mean": mean, "std": 0.0}


def _entry(t, d, e, success=1.0):
    return {"transparency": _stat(t), "d_hat": _stat(d), "e_hat": _stat(e), "success": _stat(success),
            "legibility": _stat(0.5), "seconds": _stat(0.1), "n": 10}


def test_claims_on_the_layout_groups():
    summ = {"navigation": {
        "layouts_ambiguous": {"dp": _entry(0.50, 0.4, 0.7), "ld": _entry(0.55, 0.9, 0.1), "scdp": _entry(0.60, 0.6, 0.5)},
        "layouts_clear": {"dp": _entry(0.60, 0.4, 0.7), "ld": _entry(0.40, 0.9, 0.1), "scdp": _entry(0.70, 0.3, 0.9, 0.97)},
    }}
    judged = {c["claim"]: c for c in claims.claims(summ, tables.LAYOUT_GROUPS, protocol="per_layout")}
    assert len(judged) == 5 and all(c["protocol"] == "per_layout" for c in judged.values())
    assert judged["SCDP has the best T_fa in non-ambiguous scenes (of dp, ld, scdp)"]["holds"]
    assert judged["SCDP beats DP in ambiguous scenes (T_fa)"]["holds"]
    assert judged["LD is the most detached and the least efficient (of dp, ld, scdp; layouts_clear)"]["holds"]
    success = judged["success >= 0.98 for every method (dp, ld, scdp; Dataset row excluded) on layouts_ambiguous, layouts_clear"]
    assert not success["holds"] and success["numbers"] == {"layouts_clear/scdp": 0.97, "methods": ["dp", "ld", "scdp"],
                                                           "scene_sets": ["layouts_ambiguous", "layouts_clear"]}

    summ["navigation"]["layouts_clear"]["dp"] = _entry(0.80, 0.95, 0.7)  # DP now best T and most detached
    judged = {c["claim"]: c for c in claims.claims(summ, tables.LAYOUT_GROUPS, protocol="per_layout")}
    assert not judged["SCDP has the best T_fa in non-ambiguous scenes (of dp, ld, scdp)"]["holds"]
    assert not judged["LD is the most detached and the least efficient (of dp, ld, scdp; layouts_clear)"]["holds"]
    del summ["navigation"]["layouts_clear"]  # only some layouts ran: nothing to judge
    assert claims.claims(summ, tables.LAYOUT_GROUPS) == []


def test_table3_sets_the_protocols_side_by_side():
    methods = {m: _entry(0.5, 0.5, 0.5) for m in ("dp", "ld", "scdp", "dataset")}
    full = {"navigation": {"layouts_ambiguous": methods, "layouts_clear": methods}}
    half = {"navigation": {"layouts_ambiguous": {m: _entry(0.25, 0.5, 0.5) for m in methods}}}
    table = tables.table3({"random": full, "per_layout": half})
    rows = [r for r in table.splitlines() if r.startswith("| ")]
    assert sum("Dataset" in r for r in rows) == 2  # once for our demos, once for the paper
    scdp_rows = [r for r in rows if r.startswith("| Ours (SCDP)")]
    assert [r.split(" | ")[1] for r in scdp_rows] == ["random-scene models", "per-layout models", "paper"]
    assert "0.25 ± 0.00" in scdp_rows[1] and scdp_rows[1].count("–") == 4  # clear layouts did not run
    assert "0.59 ± 0.03" in scdp_rows[2]  # the paper's Navigation T in ambiguous scenes
    assert r"\begin{tabular}" in tables.table3({"random": full}, "tex")


def test_a_stage_that_forgets_inputs_cannot_be_built():
    """Stage's four methods are abstract: a stage without ``inputs`` would otherwise compare its
    None with a missing record's None and be skipped as up to date for ever."""
    class Forgetful(Stage):
        name = "forgetful"

        def recorded(self):
            return None

        def make(self, inputs):
            pass

        def outputs(self):
            return {}

    with pytest.raises(TypeError, match="inputs"):
        Forgetful()
