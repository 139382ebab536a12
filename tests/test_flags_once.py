"""Knobs declared once (issue 78): each ``scdp study make`` screening flag takes its type, default and help from its
field of :class:`scdp.study.rules.Screening`, each ``scdp serve`` batching flag its name, bounds, default and help
from :class:`scdp.serve.batching.BatchingOptions`, the simulated person's and ``study power``'s from
:class:`~scdp.study.person.ParticipantModel` and :class:`~scdp.study.power_settings.PowerSettings`, and no parser
writes one again."""

import inspect
from dataclasses import fields
from pathlib import Path

from scdp.cli import study as study_cli
from scdp.cli import study_parser
from scdp.cli.parser import build_parser
from scdp.cli.types import count, seed
from scdp.serve.batcher import DynamicBatcher
from scdp.serve.batching import BatchingOptions
from scdp.study.person import ParticipantModel
from scdp.study.power_settings import PowerSettings
from scdp.study.record import StudyConfig
from scdp.study.rules import Screening, values_of


def command(*path: str):
    parser = build_parser()
    for name in path:
        parser = parser._subparsers._group_actions[0].choices[name]
    return parser


def make_actions() -> dict:
    return {a.dest: a for a in command("study", "make")._actions}


def test_every_screening_flag_comes_from_its_field():
    actions = make_actions()
    for f in fields(Screening):
        action = actions[f.name]
        assert action.default == f.default and action.type is f.metadata["type"], f.name
        shown = f"{f.default:g}" if isinstance(f.default, float) else f.default
        assert action.help.startswith(f.metadata["help"]) and action.help.endswith(f"(default {shown})"), f.name
        assert action.choices == f.metadata.get("choices"), f.name


def test_every_study_setting_flag_comes_from_its_field():
    actions = make_actions()
    flagged = [f for f in fields(StudyConfig) if f.metadata]
    assert len(flagged) == 14  # every setting study make takes; the server's timing rules have no flag
    for f in flagged:
        action = actions[f.name]
        assert action.option_strings == [f.metadata.get("flag", "--" + f.name.replace("_", "-"))], f.name
        assert action.default == f.default and action.help.startswith(f.metadata["help"]), f.name
    assert actions["scenes_per_set"].type is count and actions["seed"].type is seed  # the named types, resolved


def test_the_parsed_rules_are_the_fields_own():
    args = build_parser().parse_args(["study", "make", "--task", "navigation", "--checkpoints", "c", "--out", "o",
                                      "--max-away", "5", "--ahead-observer", "any"])
    assert Screening.from_args(args) == Screening(max_away=5, ahead_observer="any")
    config = StudyConfig.from_args(args)
    assert config == StudyConfig(screening=Screening(max_away=5, ahead_observer="any"))


def test_no_parser_declares_a_screening_or_batching_flag_again():
    cli = Path(__file__).parents[1] / "src" / "scdp" / "cli"
    text = "".join(p.read_text() for p in cli.glob("*.py"))
    for flag in [f'"--{f.name.replace("_", "-")}"' for f in fields(Screening)] + [
            f'"{f.metadata["flag"]}"' for f in fields(BatchingOptions)]:
        assert flag not in text, flag
    study = inspect.getsource(study_parser._make) + inspect.getsource(study_cli.make)  # other commands have a --seed
    for f in (f for f in fields(StudyConfig) if f.metadata):
        assert f'"{f.metadata.get("flag", "--" + f.name.replace("_", "-"))}"' not in study, f.name


def test_every_batching_flag_comes_from_its_field():
    actions = {a.dest: a for a in command("serve")._actions}
    for f in fields(BatchingOptions):
        action = actions[f.name]
        assert action.option_strings == [f.metadata["flag"]] and action.default == f.default, f.name
        assert action.help == f"{f.metadata['help']} (default {f.default:g})", f.name
    lo, hi = fields(BatchingOptions)[1].metadata["range"]
    assert actions["max_wait_ms"].type(str(hi)) == hi  # the bounds come from the field too
    args = build_parser().parse_args(["serve", "--task", "navigation", "--checkpoints", "c", "--max-batch", "3",
                                      "--timeout", "2"])
    assert BatchingOptions.from_args(args) == BatchingOptions(max_batch=3, timeout_s=2.0)


def test_the_batcher_takes_its_defaults_from_the_options():
    batcher = DynamicBatcher(lambda key, items: items)
    assert batcher.max_batch == BatchingOptions.max_batch and batcher.max_wait_s == BatchingOptions.max_wait_ms / 1000


def test_every_simulated_person_and_power_flag_comes_from_its_field():
    """``study simulate`` and ``study power`` take --noise and --delay-s from the simulated person's fields, and
    power's settings from PowerSettings': the same default, type bounds and help in both commands."""
    simulate, power = ({a.dest: a for a in command("study", c)._actions} for c in ("simulate", "power"))
    for actions, cls in ((simulate, ParticipantModel), (power, ParticipantModel), (power, PowerSettings)):
        for f in (f for f in fields(cls) if f.metadata):
            action = actions[f.name]
            assert action.option_strings == [f.metadata.get("flag", "--" + f.name.replace("_", "-"))], f.name
            assert action.default == f.default and action.help.startswith(f.metadata["help"]), f.name
    assert simulate["noise"].help == power["noise"].help
    assert power["target"].type("0.5") == 0.5 and power["participants"].nargs == "+"
    args = build_parser().parse_args(["study", "power", "--study", "s", "--out", "o", "--set", "clear",
                                      "--participants", "6", "12", "--noise", "0.2"])
    assert PowerSettings(**values_of(PowerSettings, args)) == PowerSettings(scene_set="clear", participants=(6, 12))
    assert ParticipantModel(**values_of(ParticipantModel, args)) == ParticipantModel(noise=0.2)
    both = inspect.getsource(study_parser._simulate) + inspect.getsource(study_parser._power)
    for source, cls in ((both, ParticipantModel), (inspect.getsource(study_parser._power), PowerSettings)):
        for f in (f for f in fields(cls) if f.metadata):  # simulate's own --seed and --participants are other knobs
            assert f'"{f.metadata.get("flag", "--" + f.name.replace("_", "-"))}"' not in source, f.name
