"""PlannerSpec (which planner, parsed once) and PlanningOptions (how it plans), as every entry point uses them."""

import pytest

from scdp.cli.parser import build_parser
from scdp.config import PlannerSpec, PlanningOptions
from scdp.errors import ScdpError


def test_every_spelling_of_one_planner_is_one_spec():
    forms = [PlannerSpec.parse("scdp_legible"), PlannerSpec.parse("scdp:legible"), PlannerSpec.of("scdp", "legible"),
             PlannerSpec.of("scdp_legible", "legible")]
    assert all(f == forms[0] and hash(f) == hash(forms[0]) for f in forms)
    assert (forms[0].method, forms[0].style) == ("scdp", "legible")
    assert [f.label for f in forms] == ["scdp_legible", "scdp:legible", "scdp", "scdp_legible"]  # as written
    assert PlannerSpec.parse("scdp") == PlannerSpec.parse("scdp:auto") != PlannerSpec.parse("scdp_blend")
    assert PlannerSpec.parse("dp") == PlannerSpec.of("dp") and PlannerSpec.parse("dp").style is None
    assert PlannerSpec.parse("ld") != PlannerSpec.parse("ld_paper")
    assert PlannerSpec.parse("scdp_paper").has_encoder and not PlannerSpec.parse("ld").has_encoder


@pytest.mark.parametrize("method, style, field, words", [
    ("dp", "legible", "--style", "has no style choice"),
    ("scdp_paper", "auto", "--style", "has no style choice"),
    ("scdp_legible", "efficient", "--style", "fixes the style 'legible'"),
    ("scdp", "bold", "--style", "unknown style"),
    ("rrt", None, "--method", "unknown method"),
])
def test_a_style_the_method_cannot_take_is_refused(method, style, field, words):
    with pytest.raises(ScdpError) as err:
        PlannerSpec.of(method, style)
    assert err.value.field == field and words in err.value.message


@pytest.mark.parametrize("text, words", [("foo", "unknown method"), ("dp:legible", "only scdp takes a style"),
                                         ("scdp:bold", "only scdp takes a style")])
def test_a_bad_method_spec_is_refused(text, words):
    with pytest.raises(ScdpError) as err:
        PlannerSpec.parse(text, field="--methods")
    assert err.value.field == "--methods" and words in err.value.message


def test_each_planning_option_is_a_flag_of_every_planning_command_and_reads_back():
    parser = build_parser()
    flags = [flag for flag, _ in PlanningOptions.flags()]
    assert flags == ["--sampler", "--steps", "--warm-skip", "--device", "--runtime"]
    base = {"plan": ["--task", "navigation", "--checkpoints", "c", "--goals", "2,0.3", "2,-0.3", "--out", "o.json"],
            "evaluate": ["--task", "navigation", "--checkpoints", "c"], "serve": ["--task", "navigation", "--checkpoints", "c"],
            "deploy": ["--checkpoints", "c", "--out", "o"]}
    for command, args in base.items():
        parsed = parser.parse_args([command, *args, "--sampler", "ddim", "--steps", "7", "--warm-skip", "3", "--device", "cpu",
                                    "--runtime", "onnx"])
        assert PlanningOptions.from_args(parsed) == PlanningOptions(sampler="ddim", steps=7, warm_skip=3, device="cpu",
                                                                    runtime="onnx"), command
        assert PlanningOptions.from_args(parser.parse_args([command, *args])) == PlanningOptions(device="auto"), command


def test_evaluate_parses_its_methods_into_specs():
    parsed = build_parser().parse_args(["evaluate", "--task", "navigation", "--checkpoints", "c",
                                        "--methods", "dp", "scdp:legible"])
    assert parsed.methods == [PlannerSpec.parse("dp"), PlannerSpec.parse("scdp_legible")]
    assert [m.label for m in parsed.methods] == ["dp", "scdp:legible"]


def test_the_runtime_is_checked_where_the_options_are_made():
    assert PlanningOptions(runtime="onnx").runtime == "onnx"
    for bad, words in [({"runtime": "tensorrt"}, "one of torch, onnx"), ({"runtime": "onnx", "device": "cuda"}, "runs on the CPU")]:
        with pytest.raises(ScdpError) as err:
            PlanningOptions(**bad)
        assert err.value.field == "--runtime" and words in err.value.message
