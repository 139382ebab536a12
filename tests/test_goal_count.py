"""How many goals a scene may hold: 2..5 everywhere (scdp.keys.MIN_GOALS, MAX_GOALS), refused on one line otherwise."""

import numpy as np
import pytest

from scdp.cli import main
from scdp.config import EncoderConfig
from scdp.errors import ScdpError
from scdp.keys import MAX_GOALS
from scdp.tasks import BLOCK_REACH, NAVIGATION

FAN = [[2.0, 1.0], [2.0, 0.0], [2.0, -1.0], [1.5, 1.8], [1.5, -1.8], [2.3, 0.5]]  # six spread Navigation goals


@pytest.mark.parametrize("task", [NAVIGATION, BLOCK_REACH], ids=lambda t: t.name)
@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_scenes_of_two_to_five_goals_are_drawn_and_accepted(task, n):
    goals = task.sample_goals(np.random.default_rng(n), n)
    assert goals.shape == (n, task.space_dim)
    assert np.array_equal(task.validate_goals(goals, n - 1), goals)


@pytest.mark.parametrize("n, words", [(0, "at least two goals"), (1, "at least two goals"), (6, "at most 5 goals")])
def test_a_scene_of_too_few_or_too_many_goals_is_refused(n, words):
    with pytest.raises(ScdpError) as err:
        NAVIGATION.validate_goals(FAN[:n] if n else np.zeros((0, 2)))
    assert err.value.field == "goals" and words in err.value.message
    with pytest.raises(ScdpError):
        NAVIGATION.sample_goals(np.random.default_rng(0), n)
    with pytest.raises(ScdpError) as err:
        EncoderConfig(n_goals=n)
    assert err.value.field == "n_goals"


@pytest.mark.parametrize("goals, pair", [([[2.0, 1.0], [2.0, 0.0], [2.0, 0.0]], "goals 1 and 2"),  # two distractors
                                         ([[2.0, 1.0], [2.0, 0.0], [2.0, 1.0]], "goals 0 and 2")])  # one on the target
def test_negatives_that_coincide_with_the_target_or_each_other_are_refused(goals, pair):
    with pytest.raises(ScdpError) as err:
        NAVIGATION.validate_goals(goals, 0)
    assert pair in err.value.message and "apart" in err.value.message


def test_the_cli_refuses_six_goals_on_one_line(tmp_path, capsys):
    goals = [f"{x},{y}" for x, y in FAN]
    assert main(["plot-ellipse", "--task", "navigation", "--goals", *goals, "--out", str(tmp_path / "e.png")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("scdp: error: goals: at most 5 goals")
    assert not (tmp_path / "e.png").exists()


def test_the_service_schema_takes_at_most_five_goals():
    from scdp.serve.app import ActRequest, PlanRequest

    for model in (ActRequest, PlanRequest):
        schema = model.model_json_schema()["properties"]
        assert schema["goals"]["maxItems"] == MAX_GOALS and schema["target"]["maximum"] == MAX_GOALS - 1
