"""What a trained part depends on (scdp.training.recipe, scdp.pipeline.fingerprints): an option that
changes a part's weights retrains exactly the parts that depend on it; an evaluation-only change
retrains none; changed weights upstream retrain what starts from them; file times play no part."""

import json
import os
from dataclasses import replace

import numpy as np
import pytest

from scdp.content import RECORD, digest
from scdp.pipeline.plan import adopt_outputs
from scdp.pipeline.stages import ModelSet, PartStage, checkpoint_state
from scdp.presets import PRESETS
from scdp.tasks import get_task
from scdp.training.made_from import write_record
from scdp.training.recipe import model_parts, part_recipe

CPU = PRESETS["cpu"]
PARTS = ("encoder",) + model_parts(CPU)
STYLES = ("style_legible", "style_efficient")
PAPER = ("style_paper_legible", "style_paper_efficient")

# option -> the parts whose own recipe it changes
WEIGHT_OPTIONS = {
    "base.model.kernel_size=3": {"base", "ld"},
    "base.train.min_steps=100": {"base"},
    "data.base_demos=50": {"base", "ld"},
    "encoder.train.epochs=3": {"encoder"},
    "encoder.model.context_dim=32": {"encoder"},
    "data.encoder_scenes=100": {"encoder"},
    "style.model.noise_window=0.5": set(STYLES),
    "style.model.film_blocks=bottleneck": set(STYLES),
    "style.early_windows=0.3": set(STYLES),
    "style.x0_weight_cap=2": set(STYLES),
    "style.windows=rest": set(STYLES),
    "style.train.lr=0.0003": set(STYLES),
    "style.efficient_score=transparency": {"style_efficient"},
    "style.legible_score=d_hat": {"style_legible"},
    "style.legible_score=viewpoint_legibility": {"style_legible"},
    "paper_style.legible_score=legibility": {"style_paper_legible"},
    "data.style_fraction=0.3": set(STYLES) | set(PAPER),
    "paper_style.model.hidden=32": set(PAPER),
    "paper_style.early_windows=0.5": set(PAPER),
    "ld.guidance.p_uncond=0.2": {"ld"},
    "ld.init=scratch": {"ld"},
    "ld.train.min_steps=10": {"ld"},
}
# planning- and evaluation-time options: no part's weights depend on them
EVALUATION_ONLY = ["evaluation.scenes=200", "evaluation.seed=7", "ld.guidance.w0=1", "ld.guidance.alpha=0.5",
                   "ld.guidance.decay=0.8", "ld.guidance.window=0.5", "style.arbitration=ellipse",
                   "paper_style.arbitration=probabilistic", "base.model.sampler=ddim", "base.model.num_inference_steps=5",
                   "layouts.demos=7"]


@pytest.mark.parametrize("option", sorted(WEIGHT_OPTIONS))
def test_a_weight_option_changes_exactly_its_parts_recipes(option):
    changed = CPU.with_overrides([option])
    differs = {p for p in PARTS if part_recipe(changed, p) != part_recipe(CPU, p)}
    assert differs == WEIGHT_OPTIONS[option]


def test_evaluation_only_options_change_no_recipe():
    changed = CPU.with_overrides(EVALUATION_ONLY)
    assert all(part_recipe(changed, p) == part_recipe(CPU, p) for p in PARTS)


def test_a_changed_preset_definition_is_seen_without_overrides():
    """Upgrading the preset's own definition (not a --set) must not reuse stale predictors."""
    upgraded = replace(CPU, style=replace(CPU.style, model=replace(CPU.style.model, noise_window=0.5)))
    assert upgraded.overrides == CPU.overrides
    assert part_recipe(upgraded, "style_legible") != part_recipe(CPU, "style_legible")


def _train_fake_set(folder, preset):
    """A finished model set as reproduce leaves it: each part with its weights and the inputs it recorded."""
    ms = ModelSet(get_task("navigation"), preset, folder, folder / "checkpoints" / "encoder")
    (folder / "demos.zarr").mkdir(parents=True)
    for part in PARTS:  # in training order: each records the weights of the parts it starts from
        out = ms.encoder_dir if part == "encoder" else ms.checkpoints / part
        out.mkdir(parents=True)
        meta = {"part": part, "complete": True}
        (out / "config.json").write_text(json.dumps(meta))
        (out / "model.safetensors").write_bytes(f"weights of {part}".encode())
        write_record(out, ms.part_inputs(part))
    return ms


def _states(ms, preset):
    def folder(part):
        return ms.encoder_dir if part == "encoder" else ms.checkpoints / part
    return {p: checkpoint_state(folder(p), p, replace(ms, preset=preset).part_inputs(p)) for p in PARTS}


def test_up_to_date_check_follows_the_recipe(tmp_path):
    ms = _train_fake_set(tmp_path, CPU)
    assert set(_states(ms, CPU).values()) == {"done"}
    assert set(_states(ms, CPU.with_overrides(EVALUATION_ONLY)).values()) == {"done"}
    for option, parts in WEIGHT_OPTIONS.items():
        states = _states(ms, CPU.with_overrides([option]))
        assert {p for p, s in states.items() if s != "done"} == parts, option


def test_a_retrained_base_retrains_what_is_trained_from_it(tmp_path):
    ms = _train_fake_set(tmp_path, CPU)
    (ms.checkpoints / "base" / "model.safetensors").write_bytes(b"the base, retrained")
    stale = {p for p, s in _states(ms, CPU).items() if s != "done"}
    assert stale == set(STYLES) | set(PAPER) | {"ld"}  # cpu's LD base is fine-tuned from DP's (ld.init=base)
    scratch = CPU.with_overrides(["ld.init=scratch"])
    other = _train_fake_set(tmp_path / "b", scratch)
    (other.checkpoints / "base" / "model.safetensors").write_bytes(b"the base, retrained")
    assert {p for p, s in _states(other, scratch).items() if s != "done"} == set(STYLES) | set(PAPER)
    third = _train_fake_set(tmp_path / "c", CPU)
    (third.encoder_dir / "model.safetensors").write_bytes(b"the encoder, retrained")
    assert {p for p, s in _states(third, CPU).items() if s != "done"} == set(STYLES) | set(PAPER)  # only they read the scenes


def test_file_times_play_no_part(tmp_path):
    ms = _train_fake_set(tmp_path, CPU)
    rng = np.random.default_rng(0)
    for path in sorted(tmp_path.rglob("*")):  # every file and folder gets a time in random order
        when = float(rng.integers(1, 10**9))
        os.utime(path, (when, when))
    assert set(_states(ms, CPU).values()) == {"done"}


def test_a_part_without_a_record_of_its_inputs_is_retrained_unless_adopted(tmp_path):
    """A part trained before parts recorded their inputs (its recipe in config.json, no inputs.json)
    is retrained, or with --adopt taken as made from today's inputs when its recipe is today's."""
    ms = _train_fake_set(tmp_path, CPU)
    folder = ms.checkpoints / "style_legible"
    (folder / RECORD).unlink()
    meta = json.loads((folder / "config.json").read_text())
    (folder / "config.json").write_text(json.dumps({**meta, "recipe": part_recipe(CPU, "style_legible")}))
    assert {p for p, s in _states(ms, CPU).items() if s != "done"} == {"style_legible"}
    stages = [PartStage(ms, p) for p in PARTS]
    assert adopt_outputs(stages) == ["style_legible"]
    assert set(_states(ms, CPU).values()) == {"done"}
    assert adopt_outputs(stages) == []  # a recorded part is never adopted again
    other = CPU.with_overrides(["style.train.lr=0.0003"])
    (folder / RECORD).unlink()
    assert adopt_outputs([PartStage(replace(ms, preset=other), p) for p in PARTS]) == []  # another recipe: not adopted


def test_a_record_that_predates_an_input_is_adopted_only_where_it_agrees(tmp_path):
    """A record without the task (written before tasks were keyed) is adopted; one whose recipe
    differs is not, and neither is one that names another task."""
    ms = _train_fake_set(tmp_path, CPU)
    for part in ("base", "ld"):
        folder = ms.checkpoints / part
        record = json.loads((folder / RECORD).read_text())
        write_record(folder, {k: v for k, v in record.items() if k != "task"})
    write_record(ms.checkpoints / "ld", {**json.loads((ms.checkpoints / "ld" / RECORD).read_text()), "recipe": digest("old")})
    assert {p for p, s in _states(ms, CPU).items() if s != "done"} == {"base", "ld"}
    assert adopt_outputs([PartStage(ms, p) for p in PARTS]) == ["base"]
    assert {p for p, s in _states(ms, CPU).items() if s != "done"} == {"ld"}


def test_an_unfinished_part_resumes_only_with_its_own_inputs(tmp_path):
    ms = _train_fake_set(tmp_path, CPU)
    folder = ms.checkpoints / "style_legible"
    inputs = ms.part_inputs("style_legible")
    meta = json.loads((folder / "config.json").read_text())
    (folder / "config.json").write_text(json.dumps({**meta, "complete": False}))
    assert checkpoint_state(folder, "style_legible", inputs) == "missing"  # nothing to resume from
    (folder / "train_state.json").write_text(json.dumps({"job": {**inputs, "schedule": {}, "processes": 1}}))
    assert checkpoint_state(folder, "style_legible", inputs) == "partial"
    other = replace(ms, preset=CPU.with_overrides(["style.early_windows=0.3"])).part_inputs("style_legible")
    assert checkpoint_state(folder, "style_legible", other) == "missing"
