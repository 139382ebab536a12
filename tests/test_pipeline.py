"""The reproduction pipeline's bookkeeping: per-configuration presets, the stage plan,
stale outputs, and the paper's claims judged on each protocol."""

import json
import os
from dataclasses import replace

import pytest

from scdp.config import PRESETS, Preset
from scdp.errors import ScdpError
from scdp.evaluation import report
from scdp.pipeline import _checkpoint_state, plan_stages
from scdp.tasks import get_task


def test_for_config_trains_on_that_configuration_with_its_own_schedule():
    cpu = PRESETS["cpu"]
    p3, p4 = cpu.for_config(3), cpu.for_config(4)
    assert p3.num_demos == cpu.config_demos and p3.num_demos != cpu.num_demos
    assert p3.base == cpu.config_base != cpu.base and p3.style == cpu.config_style != cpu.style
    assert p3.demo_seed != p4.demo_seed  # each configuration draws its own demos
    assert (p3.down_dims, p3.encoder, p3.eval_seed) == (cpu.down_dims, cpu.encoder, cpu.eval_seed)
    paper = PRESETS["paper"]
    assert paper.for_config(1).base == paper.base  # no per-configuration schedule: the main one
    with pytest.raises(ScdpError) as err:
        cpu.for_config(7)
    assert err.value.field == "config"


@pytest.mark.parametrize("change, field", [({"config_demos": 0}, "config_demos"), ({"style_fraction": 1.5}, "style_fraction"),
                                           ({"eval_scenes": -1}, "eval_scenes")])
def test_preset_is_validated_on_construction(change, field):
    with pytest.raises(ScdpError) as err:
        replace(PRESETS["cpu"], **change)
    assert err.value.field == field


def test_preset_round_trips_through_json():
    cpu = PRESETS["cpu"]
    assert Preset.from_dict(json.loads(json.dumps(cpu.to_dict()))) == cpu


def test_stage_plan_per_protocol(tmp_path):
    task, tiny = get_task("navigation"), PRESETS["tiny"]
    names = [n for n, _, _ in plan_stages(task, tiny, tmp_path, "both", [2, 5])]
    assert names[:2] == ["ambiguity", "encoder"] and names[-1] == "per_config/evaluate"
    assert {"demos", "base", "style_legible", "style_efficient", "ld", "evaluate"} <= set(names)
    for k in (2, 5):
        assert [n for n in names if n.startswith(f"per_config/config_{k}/")] == [
            f"per_config/config_{k}/{s}" for s in ("demos", "base", "style_legible", "style_efficient", "ld")]
    assert not any(n.startswith("per_config/config_1/") for n in names)

    stages = plan_stages(task, tiny, tmp_path, "per_config", [2])
    assert "evaluate" not in [n for n, _, _ in stages] and "base" not in [n for n, _, _ in stages]
    config_set = next(ms for n, _, ms in stages if n == "per_config/config_2/base")
    assert config_set.folder == tmp_path / "per_config" / "config_2" and config_set.scenes == "config_2"
    assert config_set.encoder_dir == tmp_path / "checkpoints" / "encoder"  # the task's shared encoder
    assert config_set.preset == tiny.for_config(2)
    assert not any(n.startswith("per_config") for n, _, _ in plan_stages(task, tiny, tmp_path, "random"))


def _fake_checkpoint(folder, part, preset, *, complete=True, when=2000):
    folder.mkdir(parents=True)
    schedule = preset.base if part in ("base", "ld") else preset.style
    meta = {"part": part, "preset": preset.name, "train": schedule.to_dict(), "complete": complete}
    (folder / "config.json").write_text(json.dumps(meta))
    (folder / "model.safetensors").write_bytes(b"weights")
    os.utime(folder / "model.safetensors", (when, when))


def test_a_checkpoint_older_than_its_inputs_is_retrained(tmp_path):
    tiny = PRESETS["tiny"]
    demos = tmp_path / "demos.zarr"
    demos.mkdir()
    os.utime(demos, (1000, 1000))
    base = tmp_path / "checkpoints" / "base"
    _fake_checkpoint(base, "base", tiny)
    assert _checkpoint_state(base, "base", tiny, [demos]) == "done"
    os.utime(demos, (3000, 3000))  # the demos were regenerated after the base was trained
    assert _checkpoint_state(base, "base", tiny, [demos]) == "missing"
    assert _checkpoint_state(base, "base", PRESETS["cpu"], []) == "missing"  # another preset's schedule

    style = tmp_path / "checkpoints" / "style_legible"
    _fake_checkpoint(style, "style_legible", tiny, complete=False)
    assert _checkpoint_state(style, "style_legible", tiny) == "missing"  # nothing to resume from
    (style / "train_state.json").write_text("{}")
    assert _checkpoint_state(style, "style_legible", tiny) == "partial"


def _stat(mean):
    return {"mean": mean, "std": 0.0}


def _entry(t, d, e, success=1.0):
    return {"transparency": _stat(t), "d_hat": _stat(d), "e_hat": _stat(e), "success": _stat(success),
            "legibility": _stat(0.5), "seconds": _stat(0.1), "n": 10}


def test_claims_on_the_configuration_groups():
    summ = {"navigation": {
        "configs_ambiguous": {"dp": _entry(0.50, 0.4, 0.7), "ld": _entry(0.55, 0.9, 0.1), "scdp": _entry(0.60, 0.6, 0.5)},
        "configs_clear": {"dp": _entry(0.60, 0.4, 0.7), "ld": _entry(0.40, 0.9, 0.1), "scdp": _entry(0.70, 0.3, 0.9, 0.97)},
    }}
    judged = {c["claim"]: c for c in report.claims(summ, report.CONFIG_SETS, protocol="per_config")}
    assert len(judged) == 5 and all(c["protocol"] == "per_config" for c in judged.values())
    assert judged["SCDP has the best T in non-ambiguous scenes"]["holds"]
    assert judged["SCDP beats DP in ambiguous scenes (T)"]["holds"]
    assert judged["LD is the most detached and the least efficient (configs_clear)"]["holds"]
    success = judged["success >= 0.98 for every method"]
    assert not success["holds"] and success["numbers"] == {"configs_clear/scdp": 0.97}

    summ["navigation"]["configs_clear"]["dp"] = _entry(0.80, 0.95, 0.7)  # DP now best T and most detached
    judged = {c["claim"]: c for c in report.claims(summ, report.CONFIG_SETS, protocol="per_config")}
    assert not judged["SCDP has the best T in non-ambiguous scenes"]["holds"]
    assert not judged["LD is the most detached and the least efficient (configs_clear)"]["holds"]
    del summ["navigation"]["configs_clear"]  # only some configurations ran: nothing to judge
    assert report.claims(summ, report.CONFIG_SETS) == []


def test_table3_sets_the_protocols_side_by_side():
    methods = {m: _entry(0.5, 0.5, 0.5) for m in ("dp", "ld", "scdp", "dataset")}
    full = {"navigation": {"configs_ambiguous": methods, "configs_clear": methods}}
    half = {"navigation": {"configs_ambiguous": {m: _entry(0.25, 0.5, 0.5) for m in methods}}}
    table = report.table3({"random": full, "per_config": half})
    rows = [r for r in table.splitlines() if r.startswith("| ")]
    assert sum("Dataset" in r for r in rows) == 2  # once for our demos, once for the paper
    scdp_rows = [r for r in rows if r.startswith("| Ours (SCDP)")]
    assert [r.split(" | ")[1] for r in scdp_rows] == ["random-scene models", "per-configuration models", "paper"]
    assert "0.25 ± 0.00" in scdp_rows[1] and scdp_rows[1].count("–") == 4  # clear configurations did not run
    assert "0.59 ± 0.03" in scdp_rows[2]  # the paper's Navigation T in ambiguous scenes
    assert r"\begin{tabular}" in report.table3({"random": full}, "tex")
