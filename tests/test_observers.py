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


# -- the demonstration observer (docs/observers.md), by hand -----------------------------------

S, G0, G1 = [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]


def test_the_demonstration_observer_reads_how_far_the_path_has_been_from_each_goals_demonstrations():
    families = np.array([[[S, G0]], [[S, G1]]])  # one two-point demonstration per goal
    p = observers.demonstration_posterior([S, G0], families, 0, beta=20.0)
    assert p[0].tolist() == [0.5, 0.5]  # every demonstration starts at the start
    # mean distance so far: 0 from g0's demonstration, (0 + 1) / 2 from g1's; b = 20 / |g0 - S| = 20
    assert p[1, 0] == pytest.approx(1 / (1 + np.exp(-20 * 0.5)))


def test_a_goal_is_as_likely_as_the_average_of_its_demonstrations():
    # g1 has a second demonstration that passes through g0: its likelihood is the mean of the two
    families = np.array([[[S, G0], [S, G0]], [[S, G1], [S, G0]]])
    p = observers.demonstration_posterior([S, G0], families, 0, beta=20.0)
    g1 = (np.exp(-20 * 0.5) + 1.0) / 2
    assert p[1, 0] == pytest.approx(1 / (1 + g1))


def test_the_demonstration_observer_scales_its_temperature_by_the_start_to_target_length():
    small = np.array([[[S, G0]], [[S, G1]]])
    p_small = observers.demonstration_posterior([S, G0], small, 0, beta=4.0)
    p_large = observers.demonstration_posterior(10 * np.array([S, G0]), 10 * small, 0, beta=4.0)
    assert np.allclose(p_small, p_large)


def test_the_demonstration_observer_starts_uniform_from_a_noisy_start():
    s = np.linspace(0.0, 1.0, 21)[:, None]
    families = np.array([[s * G0], [s * G1]])  # straight demonstrations, a point every 0.05
    start = [0.04, 0.0]  # nearer g0's second point than the demonstrations' start
    p = observers.demonstration_posterior([start, [0.5, 0.0], G0], families, 0)
    assert p[0, 0] == pytest.approx(0.5) and p[-1, 0] > 0.99
