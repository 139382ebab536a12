from dataclasses import asdict

import numpy as np
import pytest

from scdp import ambiguity, metrics
from scdp.ambiguity import AmbiguitySettings
from scdp.errors import ScdpError
from scdp.evaluation.calibration import ambiguity_report, calibrate, labelled_layouts, report_markdown
from scdp.tasks import NAVIGATION


def test_stored_settings_split_the_six_layouts_as_labelled(task):
    starts, goals, targets, labels, ids = labelled_layouts(task)
    assert list(ids) == [1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6]
    assert np.array_equal(ambiguity.probabilistic_flags(starts, goals, targets, task.ambiguity), labels)
    assert np.array_equal(ambiguity.ellipse_flags(starts, goals, targets, task.ambiguity), labels)


def test_single_scene_api_agrees_with_vectorised(task):
    s = task.ambiguity
    for goals in task.layouts:
        for method, batched in (("ellipse", ambiguity.ellipse_flags), ("probabilistic", ambiguity.probabilistic_flags)):
            single = ambiguity.is_ambiguous(task.start_point, goals[0], goals[1:], method=method, settings=s)
            assert single == bool(batched(task.start_point[None], goals[None], np.array([0]), s)[0])


def test_ellipse_geometry_by_hand():
    # focus (0,0), target (1,0), kappa 0.75, ecc 0.5: c = 0.75, a = 1.5, b = 1.5 * sqrt(0.75)
    center, M = ambiguity.ellipse([0, 0], [1, 0], 0.75, 0.5)
    assert np.allclose(center, [0.75, 0])
    b = 1.5 * np.sqrt(0.75)
    for p in ([0.75 + 1.5, 0], [0.75 - 1.5, 0], [0.75, b]):
        r = np.array(p) - center
        assert r @ M @ r == pytest.approx(1.0)
    # the test used by the policy agrees with the drawn ellipse just inside and just outside
    goals = np.array([[[1.0, 0.0], [0.75, b * 0.99], [0.75, b * 1.01], [0.75 + 1.49, 0.0]]])
    inside = ambiguity.ellipse_inside(np.zeros((1, 2)), goals, np.array([0]), 0.75, 0.5)[0]
    assert inside.tolist() == [False, True, False, True]  # the target itself never counts


def test_ellipse_follows_the_robot():
    settings = AmbiguitySettings(beta=4.0, tau=0.1, kappa=0.75, eccentricity=0.6)
    target, neg = np.array([2.0, 0.0]), np.array([[1.0, 0.3]])
    assert ambiguity.is_ambiguous([0, 0], target, neg, settings=settings)
    # once the robot is past the distractor and close to g*, the scene is no longer ambiguous
    assert not ambiguity.is_ambiguous([1.8, 0], target, neg, settings=settings)


def test_probabilistic_definition_extremes(task):
    s = task.ambiguity
    g = task.layouts[0][0]
    far_behind = task.start_point - 3 * (g - task.start_point)
    assert not ambiguity.is_ambiguous(task.start_point, g, far_behind[None], method="probabilistic", settings=s)
    nearly_same = g + np.r_[task.min_goal_separation, np.zeros(task.space_dim - 1)] * 0.5
    assert ambiguity.is_ambiguous(task.start_point, g, nearly_same[None], method="probabilistic", settings=s)


def test_margin_uses_the_observer_of_the_metrics():
    """Eq. 3's margin, recomputed point by point with the metrics' observer."""
    start, goals = np.zeros(2), np.array([[2.0, 0.3], [2.0, -0.3]])
    path = np.linspace(start, goals[0], ambiguity.PATH_POINTS)
    p = metrics.observer_posterior(path, start, goals, 4.0, np.linalg.norm(goals[0]))
    f = metrics.time_weights(len(path))
    expected = ((p[:, 0] - p[:, 1]) * f).sum() / f.sum()
    assert ambiguity.straight_margins(start[None], goals[None], np.array([0]), 4.0)[0] == pytest.approx(expected)


@pytest.mark.parametrize("field, value", [("kappa", 0.4), ("kappa", 1.0), ("eccentricity", 1.0), ("beta", 0.0),
                                          ("tau", float("nan")), ("beta", "4")])
def test_settings_are_validated(field, value):
    values = {**dict(beta=4.0, tau=0.1, kappa=0.8, eccentricity=0.9), field: value}
    with pytest.raises(ScdpError) as err:
        AmbiguitySettings(**values)
    assert err.value.field == field


def test_bad_scene_input(task):
    with pytest.raises(ScdpError, match="method"):
        ambiguity.is_ambiguous(np.zeros(2), np.ones(2), [[1, 0]], method="vibes", settings=task.ambiguity)
    with pytest.raises(ScdpError, match="NaN"):
        ambiguity.is_ambiguous(np.zeros(2), [np.nan, 1], [[1, 0]], settings=task.ambiguity)
    with pytest.raises(ScdpError, match="kappa"):
        ambiguity.is_ambiguous(np.zeros(2), np.ones(2), [[1, 0]], settings=task.ambiguity, kappa=0.3)


def test_calibration_reproduces_stored_settings():
    found = calibrate(NAVIGATION, n_random=2000)
    assert found["settings"].tau == NAVIGATION.ambiguity.tau  # tau depends only on the six layouts
    assert not found["fixed_mismatches"]["ellipse"]


def test_the_calibration_is_printed_as_the_task_field_to_paste():
    report = ambiguity_report(NAVIGATION, n_random=200)
    line = next(x for x in report_markdown(report).splitlines() if x.startswith("Calibration finds"))
    field = line.split("`")[1]
    assert field.startswith("ambiguity=AmbiguitySettings(")
    pasted = eval(field.split("=", 1)[1], {"AmbiguitySettings": AmbiguitySettings})  # noqa: S307 - the report's own text
    assert asdict(pasted) == report["calibrated_settings"]
