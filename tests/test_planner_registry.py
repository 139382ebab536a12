"""A planner is one registration (scdp.planners): one registered from a test file, with no file
under src/ touched, is parsed, loaded and evaluated by ``scdp evaluate`` beside scdp's own."""

import json
from pathlib import Path

import pytest

from helpers import straight_planner
from scdp import planners
from scdp.cli import main
from scdp.config import PlannerSpec
from scdp.errors import ScdpError
from scdp.policies.loaders import FAMILY_LOADERS, load_method

CKPT = Path(__file__).parents[1] / "results" / "cpu" / "navigation" / "checkpoints"


@pytest.fixture
def straight():
    kind = straight_planner.registered()
    yield kind
    straight_planner.removed()


def test_a_planner_registered_outside_src_runs_through_evaluate(straight, tmp_path):
    out = tmp_path / "eval.json"
    assert main(["evaluate", "--task", "navigation", "--checkpoints", str(CKPT), "--methods", "dp", "straight",
                 "--scenes", "2", "--out", str(out)]) == 0
    result = json.loads(out.read_text())
    runs = result["runs"]["ambiguous"]
    assert set(runs) == {"dp", "straight"}
    assert runs["straight"]["success"]["mean"] == 1.0  # a straight line reaches the target
    assert any(d["a"] == "straight" and d["b"] == "dp" for d in result["differences"])  # paired against dp


def test_an_unregistered_planner_is_refused_by_name(tmp_path, capsys):
    assert main(["evaluate", "--task", "navigation", "--checkpoints", str(CKPT), "--methods", "dp", "straight",
                 "--scenes", "2"]) == 2
    assert "unknown method 'straight'" in capsys.readouterr().err


def test_the_registry_is_what_specs_and_loaders_read(straight):
    spec = PlannerSpec.parse("straight")
    assert spec.kind is straight and spec.parts == () and not spec.has_encoder
    assert type(load_method(spec, CKPT, None)).__name__ == "StraightLine"
    with pytest.raises(ScdpError, match="style"):
        PlannerSpec.parse("straight:legible")
    with pytest.raises(ScdpError, match="already registered"):
        planners.register(straight)


def test_scdps_own_planners_are_registered_by_family():
    assert set(FAMILY_LOADERS) == set(planners.FAMILIES)
    assert {planners.kind(m).family for m in ("dp", "ld", "ld_paper", "scdp", "scdp_legible", "scdp_paper")} == \
        {"dp", "ld", "scdp"}
    assert PlannerSpec.parse("scdp_legible") == PlannerSpec.parse("scdp:legible")
    with pytest.raises(ScdpError, match="no loader"):
        planners.PlannerKind("mine", family="mine", parts=())


class _Point:
    """An installed package's entry point, as importlib.metadata gives it."""

    def __init__(self, name, value, load):
        self.name, self.value, self.load = name, value, load


def test_an_installed_planner_is_found_by_its_entry_point(monkeypatch, tmp_path):
    """A package declaring ``straight`` in the ``scdp.planners`` group needs no import by the user: the
    command line loads it at its first lookup."""
    kind = planners.PlannerKind("straight", family="straight", parts=(), denoiser=None,
                                load=straight_planner.load_straight)
    monkeypatch.setattr(planners, "entry_points", lambda group: [_Point("straight", "helpers.straight_planner:KIND",
                                                                        lambda: kind)] if group == planners.PLANNER_GROUP else [])
    planners._installed.cache_clear()  # as a fresh process reads the installed packages
    try:
        assert "straight" in planners.names() and "straight" not in planners.REGISTRY  # listed, not yet loaded
        assert main(["evaluate", "--task", "navigation", "--checkpoints", str(CKPT), "--methods", "dp", "straight",
                     "--scenes", "2", "--out", str(tmp_path / "eval.json")]) == 0
        assert planners.REGISTRY["straight"] is kind
    finally:
        planners.unregister("straight")
        planners._installed.cache_clear()


def test_a_broken_installed_planner_is_one_line_naming_it(monkeypatch, capsys):
    def broken():
        raise ImportError("no module named 'straightline'")

    monkeypatch.setattr(planners, "entry_points", lambda group: [_Point("straight", "straightline:KIND", broken)])
    planners._installed.cache_clear()
    try:
        assert main(["evaluate", "--task", "navigation", "--checkpoints", str(CKPT), "--methods", "straight"]) == 2
    finally:
        planners._installed.cache_clear()
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "straight" in err and "straightline:KIND" in err and "failed to load" in err
