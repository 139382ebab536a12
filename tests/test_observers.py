"""Observer measures (scdp.observers) against hand computations."""

import math

import numpy as np
import pytest

from scdp import observers

# start (0, 0), goals g0 = (1, 0) and g1 = (0, 1); the path walks straight to g0 in two steps
PATH = np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]])
GOALS = np.array([[1.0, 0.0], [0.0, 1.0]])


def p_g0_by_hand(q, beta=4.0):
    """P(g0 | S -> q), path-length observer, costs in units of ||g0 - S|| = 1."""
    c0 = math.dist(GOALS[0], q) - 1.0
    c1 = math.dist(GOALS[1], q) - 1.0
    return 1.0 / (1.0 + math.exp(-beta * (c1 - c0)))


def test_the_belief_along_a_path_is_the_path_length_observer():
    posterior = observers.posterior_along(PATH, GOALS, 0)
    expected = [0.5, p_g0_by_hand(PATH[1]), p_g0_by_hand(PATH[2])]  # 0.5, 0.9222, 0.9965
    assert np.allclose(posterior[:, 0], expected) and np.allclose(posterior.sum(axis=1), 1.0)
    assert expected[1] == pytest.approx(1 / (1 + math.exp(-4 * (math.sqrt(1.25) - 0.5))))


@pytest.mark.parametrize("threshold, expected", [(0.8, 0.5), (0.95, 1.0), (0.999, None), (0.5, 0.0)])
def test_time_to_confidence_is_where_the_belief_stays_above_the_threshold(threshold, expected):
    p = observers.posterior_along(PATH, GOALS, 0)[:, 0]
    assert observers.time_to_confidence(p, threshold) == expected


def test_a_belief_that_drops_again_restarts_the_clock_and_one_that_ends_low_is_never_confident():
    assert observers.time_to_confidence([0.5, 0.9, 0.7, 0.85, 0.9]) == 0.75  # confident from point 3 of 0..4
    assert observers.time_to_confidence([0.5, 0.9, 0.9, 0.9, 0.7]) is None
    with pytest.raises(ValueError):
        observers.time_to_confidence([0.9])


def test_prediction_is_correct_only_where_the_target_is_the_strict_arg_max():
    posterior = observers.posterior_along(PATH, GOALS, 0)
    assert observers.correct_at(posterior, 0, (0.0, 0.5, 1.0)) == [False, True, True]  # a tie at the start
    assert observers.correct_at(posterior, 1, (0.0, 0.5, 1.0)) == [False, False, False]
    assert observers.correct_at(np.array([[0.2, 0.8]] * 5), 1, (0.25,)) == [True]
    with pytest.raises(ValueError):
        observers.correct_at(posterior, 0, (1.5,))


def test_observer_measures_of_one_path():
    m = observers.observer_measures(PATH, GOALS, 0, fractions=(0.5, 1.0))
    assert m == {"time_to_confidence": 0.5, "correct_at_50": True, "correct_at_100": True}
    assert observers.observer_measures(PATH, GOALS, 1)["time_to_confidence"] is None
