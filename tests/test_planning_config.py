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


@pytest.mark.parametrize("text, words", [("foo", "unknown method"), ("dp:legible", "only scdp and scdp_student take a style"),
                                         ("scdp:bold", "only scdp and scdp_student take a style")])
def test_a_bad_method_spec_is_refused(text, words):
    with pytest.raises(ScdpError) as err:
        PlannerSpec.parse(text, field="--methods")
    assert err.value.field == "--methods" and words in err.value.message


def test_each_planning_option_is_a_flag_of_every_planning_command_and_reads_back():
    parser = build_parser()
    flags = [flag for flag, _ in PlanningOptions.flags()]
    assert flags == ["--sampler", "--steps", "--warm-skip", "--device", "--runtime", "--profile", "--cuda-graphs"]
    base = {"plan": ["--task", "navigation", "--checkpoints", "c", "--goals", "2,0.3", "2,-0.3", "--out", "o.json"],
            "evaluate": ["--task", "navigation", "--checkpoints", "c"], "serve": ["--task", "navigation", "--checkpoints", "c"],
            "deploy": ["--checkpoints", "c", "--out", "o"]}
    for command, args in base.items():
        parsed = parser.parse_args([command, *args, "--sampler", "ddim", "--steps", "7", "--warm-skip", "3", "--device", "cpu",
                                    "--runtime", "onnx", "--profile", "trained"])
        assert PlanningOptions.from_args(parsed) == PlanningOptions(sampler="ddim", steps=7, warm_skip=3, device="cpu",
                                                                    runtime="onnx"), command
        profile = "trained" if command == "evaluate" else "realtime"
        assert PlanningOptions.from_args(parser.parse_args([command, *args])) == PlanningOptions(device="auto", profile=profile)


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


ENTRY_ARGS = {"plan": ["--task", "navigation", "--checkpoints", "c", "--goals", "2,0.3", "2,-0.3", "--out", "o.json"],
              "evaluate": ["--task", "navigation", "--checkpoints", "c"], "serve": ["--task", "navigation", "--checkpoints", "c"],
              "deploy": ["--checkpoints", "c", "--out", "o"]}


def test_every_entry_point_reads_its_default_profile_from_one_table(monkeypatch):
    from scdp.config.planning import ENTRY_PROFILES
    assert {k: ENTRY_PROFILES[k] for k in ("plan", "serve", "deploy", "control_loop")} == dict.fromkeys(
        ("plan", "serve", "deploy", "control_loop"), "realtime")
    assert ENTRY_PROFILES["evaluate"] == ENTRY_PROFILES["reproduce"] == "trained"  # the paper's tables do not move
    for entry, args in ENTRY_ARGS.items():
        flipped = "trained" if ENTRY_PROFILES[entry] == "realtime" else "realtime"
        monkeypatch.setitem(ENTRY_PROFILES, entry, flipped)  # the table changes: the command follows
        assert PlanningOptions.from_args(build_parser().parse_args([entry, *args])).profile == flipped, entry
    monkeypatch.setitem(ENTRY_PROFILES, "control_loop", "trained")
    assert PlanningOptions.of_entry("control_loop").profile == "trained"


def test_a_profile_fills_only_what_was_not_given_and_only_for_the_gated_methods():
    realtime = PlanningOptions(profile="realtime", device="cpu")
    fast = realtime.for_method("scdp")
    assert (fast.sampler, fast.steps, fast.warm_skip, fast.runtime) == ("ddpm", 8, 4, "auto")
    assert realtime.for_method("dp") == fast and fast.for_method("scdp") == fast  # idempotent
    for method in ("ld", "ld_paper", "scdp_paper"):  # not covered by the gate: as trained
        kept = realtime.for_method(method)
        assert (kept.sampler, kept.steps, kept.warm_skip, kept.runtime) == (None, None, 0, "torch"), method
    given = PlanningOptions(profile="realtime", device="cpu", steps=12, runtime="torch").for_method("scdp")
    assert (given.steps, given.runtime, given.warm_skip) == (12, "torch", 6)  # flags given win; warm at half the steps
    assert PlanningOptions(profile="realtime", steps=3, warm_skip=0).for_method("dp").warm_skip == 0
    assert PlanningOptions(profile="realtime", device="cuda").for_method("dp").runtime == "torch"  # a GPU: no ONNX
    trained = PlanningOptions(device="cpu").for_method("scdp")
    assert (trained.sampler, trained.steps, trained.warm_skip, trained.runtime) == (None, None, 0, "torch")


def test_the_cuda_graph_switch_is_a_planning_option_that_reaches_the_policy_and_the_record(tmp_path):
    """--cuda-graphs on|off (a field, not an attribute to set by hand): checked where the options are
    made, set on every diffusion network a planner loads, and recorded in what scdp plan writes."""
    import json
    from pathlib import Path

    from scdp.cli import main
    from scdp.policies.loaders import load_method
    from scdp.tasks import NAVIGATION

    with pytest.raises(ScdpError, match="--cuda-graphs: on or off"):
        PlanningOptions(cuda_graphs="sometimes")
    args = build_parser().parse_args(["plan", "--task", "navigation", "--checkpoints", "c", "--goals", "2,0.2", "2,-0.2",
                                      "--out", "o.json", "--cuda-graphs", "off"])
    assert PlanningOptions.from_args(args).cuda_graphs == "off"
    ckpt = Path(__file__).parents[1] / "results" / "cpu" / "navigation" / "checkpoints"
    for graphs in ("on", "off"):
        planner = load_method("dp", ckpt, NAVIGATION, PlanningOptions(cuda_graphs=graphs, runtime="torch"))
        assert planner.placement.graphs is (graphs == "on")
    assert main(["plan", "--task", "navigation", "--checkpoints", str(ckpt), "--goals", "2,0.2", "2,-0.2",
                 "--cuda-graphs", "off", "--out", str(tmp_path / "p.json")]) == 0
    assert json.loads((tmp_path / "p.json").read_text())["planning"]["cuda_graphs"] == "off"


def test_help_text_quotes_the_constants_it_names():
    """The flags' help says the fast planner and the auto runtime's batch as the constants define them
    (they were typed by hand, and a change of REALTIME or AUTO_BATCH would have left them stale)."""
    import re
    from dataclasses import fields

    from scdp.config.planning import AUTO_BATCH, REALTIME, PlanningOptions

    help_of = {f.name: f.metadata.get("help", "") for f in fields(PlanningOptions)}
    steps, skip = re.search(r"DDPM-(\d+) warm-started at step (\d+)", help_of["profile"]).groups()
    assert (int(steps), int(skip)) == (REALTIME["steps"], REALTIME["warm_skip"])
    assert int(re.search(r"below (\d+) scenes", help_of["runtime"]).group(1)) == AUTO_BATCH
    assert f"realtime: {REALTIME['steps']})" in help_of["steps"] and f"realtime {REALTIME['warm_skip']})" in help_of["warm_skip"]
