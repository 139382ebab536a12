"""Sectioned presets: types and ranges checked on construction, overrides, the per-layout preset."""

import json
from dataclasses import replace

import pytest

from scdp.config import DataConfig, DiffusionConfig, EvaluationConfig, GuidanceConfig, Preset, StyleSection, TrainConfig
from scdp.errors import ScdpError
from scdp.presets import PRESETS, get_preset

CPU = PRESETS["cpu"]


def test_for_layout_trains_on_that_layout_with_its_own_schedule():
    p3, p4 = CPU.for_layout(3), CPU.for_layout(4)
    assert p3.data.num_demos == CPU.layouts.demos != CPU.data.num_demos
    assert p3.schedule("base") == CPU.layouts.base_train != CPU.schedule("base")
    assert p3.schedule("ld") == CPU.layouts.base_train
    assert p3.schedule("style_legible") == CPU.layouts.style_train != CPU.schedule("style_legible")
    assert p3.data.seed != p4.data.seed  # each layout draws its own demos
    assert (p3.base.model, p3.encoder, p3.evaluation) == (CPU.base.model, CPU.encoder, CPU.evaluation)
    paper = PRESETS["paper"]
    assert paper.for_layout(1).schedule("base") == paper.schedule("base")  # no per-layout schedule: the main one
    with pytest.raises(ScdpError) as err:
        CPU.for_layout(7)
    assert err.value.field == "layout"


def test_each_part_has_its_own_schedule():
    assert CPU.schedule("encoder") == CPU.encoder.train and CPU.schedule("style_efficient") == CPU.style.train
    # LD's base trains like DP's unless its section says otherwise
    assert PRESETS["paper"].schedule("ld") == PRESETS["paper"].schedule("base")
    assert CPU.schedule("ld") == CPU.ld.train and CPU.ld.init == "base"  # cpu: fine-tuned from DP's base
    own = CPU.with_overrides(['ld.train={"epochs": 3, "batch_size": 8, "lr": 0.01}'])
    assert own.schedule("ld").epochs == 3 and own.schedule("base") == CPU.schedule("base")
    with pytest.raises(ScdpError):
        CPU.schedule("head")


@pytest.mark.parametrize("make, field", [
    (lambda: TrainConfig(epochs=1, batch_size=8, lr=1e-3, warmup_steps=-1), "warmup_steps"),
    (lambda: TrainConfig(epochs=1, batch_size=8, lr=1e-3, ema_power=1.5), "ema_power"),
    (lambda: TrainConfig(epochs=1, batch_size=8, lr=1e-3, min_steps=-3), "min_steps"),
    (lambda: TrainConfig(epochs=1, batch_size=8, lr="fast"), "lr"),
    (lambda: TrainConfig(epochs=2.5, batch_size=8, lr=1e-3), "epochs"),
    (lambda: DataConfig(style_fraction=1.5), "style_fraction"),
    (lambda: DataConfig(num_demos=0), "num_demos"),
    (lambda: DiffusionConfig(horizon=15), "horizon"),
    (lambda: DiffusionConfig(sampler="euler"), "sampler"),
    (lambda: DiffusionConfig(relative_actions="yes"), "relative_actions"),
    (lambda: GuidanceConfig(alpha=1.2), "alpha"),
    (lambda: GuidanceConfig(p_uncond=0.0), "p_uncond"),
    (lambda: EvaluationConfig(methods=("dp", "magic")), "methods"),
    (lambda: EvaluationConfig(methods=("dp", "dp", "ld", "scdp")), "methods"),
    (lambda: EvaluationConfig(methods=("dp", "scdp", "scdp_legible")), "methods"),  # no ld: the paper's claims need it
    (lambda: StyleSection(early_windows=0.0), "early_windows"),
])
def test_every_field_is_checked(make, field):
    with pytest.raises(ScdpError) as err:
        make()
    assert err.value.field == field


def test_preset_round_trips_through_json_with_its_overrides():
    tuned = CPU.with_overrides(["base.train.lr=3e-4", "style.model.layers=3", "ld.guidance.w0=2",
                                "base.model.down_dims=[16, 32, 64]"])
    assert (tuned.base.train.lr, tuned.style.model.layers, tuned.ld.guidance.w0) == (3e-4, 3, 2.0)
    assert tuned.base.model.down_dims == (16, 32, 64)
    assert tuned.overrides == ("base.train.lr=3e-4", "style.model.layers=3", "ld.guidance.w0=2", "base.model.down_dims=[16, 32, 64]")
    assert Preset.from_dict(json.loads(json.dumps(tuned.to_dict()))) == tuned
    assert get_preset("cpu", ["data.num_demos=50"]).data.num_demos == 50 and CPU.data.num_demos == 1000


@pytest.mark.parametrize("assignment, says", [
    ("base.train.lr=abc", "expected float"), ("base.nope=1", "no field 'nope'"), ("data.num_demos=0", "must be > 0"),
    ("data.num_demos=1.5", "expected int"), ("evaluation.scenes=true", "expected int"), ("name=paper", "no field"),
    ("ld.guidance.alpha=2", "[0, 1]"), ("x", "section.field=value"), ("ld.init=ema", "'scratch' or 'base'"),
    ("ld.guidance.window=0", "(0, 1]"), ('style.efficient_score="speed"', "e_hat, transparency"),
])
def test_bad_overrides_name_the_field(assignment, says):
    """(An unset optional section, e.g. the paper preset's ld.train, is refused by name: see below.)"""
    with pytest.raises(ScdpError, match="^--set") as err:
        CPU.with_overrides([assignment])
    assert says in str(err.value)


def test_an_unset_section_is_refused_by_name():
    with pytest.raises(ScdpError, match="unset"):
        PRESETS["paper"].with_overrides(["ld.train.lr=1"])


def test_preset_from_dict_refuses_bad_json():
    with pytest.raises(ScdpError):
        Preset.from_dict({"name": "x", "data": {"num_demos": "many"}})
    with pytest.raises(ScdpError):
        Preset.from_dict(["not", "an", "object"])
    with pytest.raises(ScdpError):
        Preset.from_dict({"data": {}})  # no name


def test_replace_revalidates():
    with pytest.raises(ScdpError):
        replace(CPU.data, style_fraction=0)


def test_base_demos_is_checked_and_dropped_per_layout():
    fewer = get_preset("cpu", ["data.base_demos=200"])
    assert fewer.data.base_demos == 200 < fewer.data.num_demos
    assert fewer.for_layout(1).data.base_demos is None
    assert get_preset("cpu", ["data.num_demos=50", "data.base_demos=200"]).data.base_demos == 200  # more than there are: all are used
    with pytest.raises(ScdpError, match="base_demos: must be > 0"):
        get_preset("cpu", ["data.base_demos=0"])
