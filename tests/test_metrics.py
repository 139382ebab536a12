import math

import numpy as np
import pytest

from scdp import metrics


def test_detachment_by_hand():
    traj = [[0, 0], [1, 0], [2, 0]]
    expected = 1 / 1 + math.sqrt(2) / 2 + math.sqrt(5) / 3  # ||g- - s_t|| / t, t from 1
    assert metrics.detachment(traj, [0, 1]) == pytest.approx(expected)


def test_detachment_uses_nearest_of_several_distractors():
    traj = [[0, 0], [1, 0]]
    near, far = [0, 1], [0, 5]
    assert metrics.detachment(traj, [far, near]) == pytest.approx(metrics.detachment(traj, near))


def test_efficiency_is_inverse_path_length():
    traj = [[0, 0], [3, 4], [3, 5]]  # length 5 + 1
    assert metrics.efficiency(traj, eps=0.0) == pytest.approx(1 / 6)
    assert metrics.efficiency(traj) == pytest.approx(1 / (6 + 1e-6))


def test_legibility_by_hand():
    # S=(0,0), g*=(1,0), g-=(-1,0), scale-free beta=1 -> b = 1/|g*-S| = 1.
    # Q=S: P(g*)=1/2. Q=(0.5,0): costs -0.5 (g*) and +0.5 (g-) -> P = 1/(1+e^-1). f = [2, 1].
    p = 1 / (1 + math.exp(-1))
    expected = (0.5 * 2 + p * 1) / 3
    got = metrics.legibility([[0, 0], [0.5, 0]], [[1, 0], [-1, 0]], 0, beta=1.0)
    assert got == pytest.approx(expected)


def test_legibility_is_scale_free():
    traj = np.array([[0, 0], [0.3, 0.2], [0.8, 0.1], [1, 0]])
    goals = np.array([[1, 0], [1, 0.5]])
    assert metrics.legibility(traj * 7, goals * 7, 0) == pytest.approx(metrics.legibility(traj, goals, 0))


def test_observer_starts_uniform():
    p = metrics.observer_posterior([[0, 0]], np.zeros(2), np.array([[1, 0], [0, 3], [-2, 2]]), beta=5)
    assert np.allclose(p, 1 / 3)


def test_ambiguity_weight_and_transparency_by_hand():
    assert metrics.ambiguity_weight(0.5) == pytest.approx(0.5)
    assert metrics.ambiguity_weight(1.0) == pytest.approx(1 / (1 + math.exp(-1.25)))
    assert metrics.transparency(0.2, 0.8, 0.5) == pytest.approx(0.5)
    w = 1 / (1 + math.exp(2.5 * 0.5))  # j_hat = 0
    assert metrics.transparency(1.0, 0.0, 0.0) == pytest.approx(1 - w)


def test_success_radius():
    traj = [[0, 0], [0.9, 0]]
    assert metrics.success(traj, [1, 0], 0.15)
    assert not metrics.success(traj, [1, 0], 0.05)


def test_min_max_is_not_clipped():
    assert metrics.min_max(3.0, 1.0, 2.0) == pytest.approx(2.0)
    assert metrics.min_max(0.0, 1.0, 2.0) == pytest.approx(-1.0)


def test_resample_linear_in_time():
    out = metrics.resample([[0, 0], [1, 0], [3, 0]], 5)
    assert np.allclose(out[:, 0], [0, 0.5, 1, 2, 3])


def test_truncate_at_goal():
    traj = np.array([[0, 0], [0.5, 0], [0.9, 0], [1.0, 0]])
    cut = metrics.truncate_at_goal(traj, [1, 0], 0.15)
    assert len(cut) == 3 and np.allclose(cut[-1], [0.9, 0])
    assert len(metrics.truncate_at_goal(traj, [5, 5], 0.1)) == 4
