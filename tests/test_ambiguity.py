import numpy as np
import pytest

from scdp import ambiguity
from scdp.errors import ScdpError


def test_stored_settings_split_the_six_configurations_as_labelled(task):
    starts, goals, targets, labels, ids = ambiguity.fixed_scenes(task)
    s = task.ambiguity
    prob = ambiguity.straight_margins(starts, goals, targets, s.beta) < s.tau
    ell = ambiguity.ellipse_flags(starts, goals, targets, s.kappa, s.eccentricity)
    assert np.array_equal(prob, labels)
    assert np.array_equal(ell, labels)


def test_single_scene_api_agrees_with_vectorised(task):
    s = task.ambiguity
    for goals in task.fixed_configs:
        for method in ("ellipse", "probabilistic"):
            single = ambiguity.is_ambiguous(task.start_point, goals[0], goals[1:], method=method, settings=s)
            batch = (ambiguity.ellipse_flags(task.start_point[None], goals[None], np.array([0]), s.kappa, s.eccentricity)[0]
                     if method == "ellipse" else
                     ambiguity.straight_margins(task.start_point[None], goals[None], np.array([0]), s.beta)[0] < s.tau)
            assert single == bool(batch)


def test_ellipse_geometry_by_hand():
    # focus (0,0), target (1,0), kappa 0.75, ecc 0.5: c = 0.75, a = 1.5, b = 1.5 * sqrt(0.75)
    center, M = ambiguity.ellipse([0, 0], [1, 0], 0.75, 0.5)
    assert np.allclose(center, [0.75, 0])
    b = 1.5 * np.sqrt(0.75)
    for p in ([0.75 + 1.5, 0], [0.75 - 1.5, 0], [0.75, b]):
        r = np.array(p) - center
        assert r @ M @ r == pytest.approx(1.0)
    # the other focus sits at e + c, so the distances to both foci sum to 2a
    assert ambiguity.in_ellipse([0.75, b * 0.99], center, M)
    assert not ambiguity.in_ellipse([0.75, b * 1.01], center, M)


def test_ellipse_follows_the_robot():
    s = dict(kappa=0.75, eccentricity=0.6)
    from scdp.tasks import NAVIGATION

    settings = NAVIGATION.ambiguity
    target, neg = np.array([2.0, 0.0]), np.array([[1.0, 0.3]])
    assert ambiguity.is_ambiguous([0, 0], target, neg, settings=settings, **s)
    # once the robot is past the distractor and close to g*, the scene is no longer ambiguous
    assert not ambiguity.is_ambiguous([1.8, 0], target, neg, settings=settings, **s)


def test_probabilistic_definition_extremes(task):
    s = task.ambiguity
    g = task.fixed_configs[0][0]
    far_behind = task.start_point - 3 * (g - task.start_point)
    assert not ambiguity.is_ambiguous(task.start_point, g, far_behind[None], method="probabilistic", settings=s)
    nearly_same = g + np.r_[task.min_goal_separation, np.zeros(task.space_dim - 1)] * 0.5
    assert ambiguity.is_ambiguous(task.start_point, g, nearly_same[None], method="probabilistic", settings=s)


def test_bad_parameters(task):
    with pytest.raises(ScdpError, match="kappa"):
        ambiguity.ellipse(np.zeros(2), np.ones(2), 0.4, 0.5)
    with pytest.raises(ScdpError, match="eccentricity"):
        ambiguity.ellipse(np.zeros(2), np.ones(2), 0.7, 1.0)
    with pytest.raises(ScdpError, match="method"):
        ambiguity.is_ambiguous(np.zeros(2), np.ones(2), [[1, 0]], method="vibes", settings=task.ambiguity)
    with pytest.raises(ScdpError, match="NaN"):
        ambiguity.is_ambiguous(np.zeros(2), [np.nan, 1], [[1, 0]], settings=task.ambiguity)


def test_calibration_reproduces_stored_settings():
    from scdp.tasks import NAVIGATION

    found = ambiguity.calibrate(NAVIGATION, n_random=2000)["settings"]
    assert found.tau == NAVIGATION.ambiguity.tau  # tau depends only on the six configurations
    assert not ambiguity.calibrate(NAVIGATION, n_random=2000)["fixed_mismatches"]["ellipse"]
