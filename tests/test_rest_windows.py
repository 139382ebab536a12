"""Style windows by the path that remains (scdp.scoring.rest) and the demos that change course part-way
(data.turning): what a style chosen mid-motion learns from."""

import json
from pathlib import Path

import numpy as np
import pytest

from scdp.data.bezier import sample_by_arc_length
from scdp.errors import ScdpError
from scdp.pipeline.fingerprints import demos_inputs
from scdp.presets import get_preset
from scdp.scoring.rest import rest_score, rest_scores, top_by_progress
from scdp.tasks import NAVIGATION

GOALS = np.array([[2.0, 0.3], [2.0, -0.3]])  # the target (0) and a distractor close beside it


def _path(points):
    """A path through ``points`` at the task's step (pieces of straight line)."""
    out = [points[0]]
    for a, b in zip(points[:-1], points[1:]):
        n = max(int(np.ceil(np.linalg.norm(b - a) / NAVIGATION.step_size)), 1)
        out += list(np.linspace(a, b, n + 1)[1:])
    return np.array(out)


def test_a_rest_that_turns_away_from_the_distractor_scores_legible_and_a_straight_rest_efficient():
    """From the same point a third of the way along a straight start: a rest that swings away from the
    distractor first reads as the target sooner (legible score > 0 = the straight rest's own) but is longer
    (efficient score < 1), the straight rest is 0 and 1, and one bending toward the distractor is below 0."""
    start, mid = np.zeros(2), np.array([0.6, 0.0])
    straight = _path([start, mid, GOALS[0]])
    away = _path([start, mid, np.array([1.2, 0.7]), GOALS[0]])
    toward = _path([start, mid, np.array([1.2, -0.5]), GOALS[0]])
    k = 30  # the point mid, on all three
    assert np.allclose(straight[k], mid) and np.allclose(away[k], mid) and np.allclose(toward[k], mid)
    assert rest_score(NAVIGATION, straight, k, GOALS, 0, "legible") == pytest.approx(0.0, abs=1e-3)
    assert rest_score(NAVIGATION, straight, k, GOALS, 0, "efficient") == pytest.approx(1.0, abs=1e-3)
    assert rest_score(NAVIGATION, away, k, GOALS, 0, "legible") > 0.05
    assert rest_score(NAVIGATION, toward, k, GOALS, 0, "legible") < -0.05
    assert rest_score(NAVIGATION, away, k, GOALS, 0, "efficient") < 0.9


def test_top_by_progress_keeps_the_best_of_every_tenth_by_hand():
    progress = np.array([0.05, 0.06, 0.07, 0.08, 0.95, 0.96])
    scores = np.array([1.0, 4.0, 3.0, 2.0, -5.0, -1.0])
    assert top_by_progress(scores, progress, 0.5).tolist() == [False, True, True, False, False, True]
    assert top_by_progress(scores, progress, 0.01).tolist() == [False, True, False, False, False, True]  # one a tenth
    with pytest.raises(ScdpError):
        top_by_progress(scores, progress, 0.0)


def test_rest_scores_give_one_score_a_step_and_late_steps_are_kept_too(small_datasets):
    """One score for every recorded step, in the windows' order; the rest ranking keeps steps from every
    tenth of the motion (a demo ranking with early windows keeps none past 15 %)."""
    from scdp.data.windows import WindowData

    dataset = small_datasets["navigation"]
    data = WindowData(dataset, 2, 8, NAVIGATION)
    scores = rest_scores(dataset, "legible")
    assert scores.shape == (len(data),) == (dataset.num_steps,)
    data.keep(top_by_progress(scores, data.progress.numpy(), 0.2))
    kept = data.progress[data.served].numpy()
    assert len(kept) == pytest.approx(0.2 * dataset.num_steps, rel=0.1)
    assert set(np.minimum((kept * 10).astype(int), 9)) == set(range(10))
    with pytest.raises(ScdpError):
        rest_scores(dataset, "fast")


def test_turning_demos_are_a_generator_setting_and_none_leaves_the_committed_demos_current():
    """data.turning changes what a model set's demos are made from; at its default 0 the record is the one
    the committed cpu demos were made under (so a fresh clone's reproduce redoes nothing)."""
    cpu = get_preset("cpu")
    committed = json.loads(Path("results/cpu/navigation/demos.inputs.json").read_text())
    assert demos_inputs(NAVIGATION, cpu, "random")["generator"] == committed["generator"]
    assert demos_inputs(NAVIGATION, cpu.with_overrides(["data.turning=0.5"]), "random")["generator"] != committed["generator"]
    with pytest.raises(ScdpError):
        cpu.with_overrides(["data.turning=2"])


def test_a_straight_demo_has_no_legible_rest_anywhere():
    """A demo that heads straight for its target never has a rest more legible than the straight one."""
    path = sample_by_arc_length(np.zeros(2), GOALS[0] / 2, GOALS[0], NAVIGATION.step_size)
    assert max(rest_score(NAVIGATION, path, k, GOALS, 0, "legible") for k in range(0, len(path) - 1, 10)) < 1e-3
