"""The study's screening rules are declared once (issue 78): each ``scdp study make`` flag of them takes its type,
default and help from its field of :class:`scdp.study.rules.Screening`, and no parser writes one again."""

from dataclasses import fields
from pathlib import Path

from scdp.cli.parser import build_parser
from scdp.study.rules import Screening


def make_actions() -> dict:
    parser = build_parser()
    study = next(a for a in parser._subparsers._group_actions[0].choices.values() if a.prog.endswith(" study"))
    make = study._subparsers._group_actions[0].choices["make"]
    return {a.dest: a for a in make._actions}


def test_every_screening_flag_comes_from_its_field():
    actions = make_actions()
    for f in fields(Screening):
        action = actions[f.name]
        assert action.default == f.default and action.type is f.metadata["type"], f.name
        assert action.help.startswith(f.metadata["help"]) and action.help.endswith(f"(default {f.default})"), f.name
        assert action.choices == f.metadata.get("choices"), f.name


def test_the_parsed_rules_are_the_fields_own():
    args = build_parser().parse_args(["study", "make", "--task", "navigation", "--checkpoints", "c", "--out", "o",
                                      "--max-away", "5", "--ahead-observer", "any"])
    rules = Screening.from_args(args)
    assert rules == Screening(max_away=5, ahead_observer="any")


def test_no_parser_declares_a_screening_flag_again():
    cli = Path(__file__).parents[1] / "src" / "scdp" / "cli"
    text = "".join(p.read_text() for p in cli.glob("*.py"))
    for f in fields(Screening):
        assert f'"--{f.name.replace("_", "-")}"' not in text, f.name
