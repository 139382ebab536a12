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


# -- the N-goal definitions (docs/goals.md), against hand computations -------------------------

def test_detachment_uses_the_distractor_the_path_stays_closest_to():
    from scdp import metrics

    path = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    near, far = np.array([1.0, 1.0]), np.array([1.0, -3.0])
    # sum_t ||g - s_t|| / t, by hand
    d_near = np.sqrt(2) / 1 + 1.0 / 2 + np.sqrt(2) / 3
    d_far = np.sqrt(10) / 1 + 3.0 / 2 + np.sqrt(10) / 3
    assert metrics.detachment(path, [far, near]) == pytest.approx(d_near)
    assert metrics.detachment(path, [far]) == pytest.approx(d_far)


def test_goal_separation_is_the_distance_to_the_nearest_distractor():
    from scdp import metrics

    goals = [[2.0, 0.0], [2.0, 1.0], [2.0, -0.5], [0.5, 0.0]]
    assert metrics.goal_separation(goals, 0) == pytest.approx(0.5)
    assert metrics.goal_separation(goals, 3) == pytest.approx(1.5)


def test_eq3_margin_compares_the_target_with_the_most_probable_distractor():
    from scdp import ambiguity

    start = np.array([0.0, 0.0])
    goals = np.array([[2.0, 0.0], [2.0, 1.0], [2.0, -2.0]])
    beta = 4.0
    # two points on the straight path: S (every goal 1/3, margin 0) and g*; weights f = 2, 1
    b = beta / 2.0
    cost = np.array([np.linalg.norm(g - goals[0]) - np.linalg.norm(g - start) for g in goals])
    p = np.exp(-b * cost) / np.exp(-b * cost).sum()
    by_hand = (2 * 0.0 + 1 * (p[0] - max(p[1], p[2]))) / 3
    got = ambiguity.straight_margins(start[None], goals[None], np.array([0]), beta, n=2)[0]
    assert got == pytest.approx(by_hand)
    assert p[1] > p[2]  # the near distractor is the competitor, not the sum of both


def test_the_ellipse_flags_a_scene_when_any_distractor_is_inside_and_the_blend_follows_the_nearest():
    from scdp import ambiguity

    settings = NAVIGATION.ambiguity
    start = np.array([[0.0, 0.0]])
    target, inside, outside = [2.0, 0.0], [1.9, 0.1], [0.5, -1.5]
    both = np.array([[target, outside, inside]])
    assert ambiguity.ellipse_inside(start, both, np.array([0]), settings.kappa, settings.eccentricity).tolist() == [[False, False, True]]
    assert ambiguity.ellipse_flags(start, both, np.array([0]), settings)[0]
    assert not ambiguity.ellipse_flags(start, np.array([[target, outside]]), np.array([0]), settings)[0]
    w_both = ambiguity.legible_weight(start, both, np.array([0]), settings)[0]
    w_inside = ambiguity.legible_weight(start, np.array([[target, inside]]), np.array([0]), settings)[0]
    w_outside = ambiguity.legible_weight(start, np.array([[target, outside]]), np.array([0]), settings)[0]
    assert w_both == pytest.approx(w_inside) and w_outside < 0.5 < w_inside
