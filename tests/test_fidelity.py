"""Style fidelity (issue 79, scdp.evaluation.fidelity): a planner that plans like the full one keeps its styles; a
planner with its films removed has no forced-style gap left and fails, on the committed Navigation models."""

from pathlib import Path

import numpy as np
import pytest

from scdp.config import PlanningOptions
from scdp.data.scenes import VALIDATION
from scdp.evaluation.fidelity import EFFICIENT, LEGIBLE, fidelity, keeps_style, path_distance, resampled
from scdp.evaluation.protocol import scene_sets
from scdp.evaluation.records import scene_bounds, score_rollout
from scdp.evaluation.rollout import rollout
from scdp.evaluation.statistics import PairedDifference
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.policies.loaders import load_method
from scdp.tasks import get_task

CKPT = Path(__file__).parents[1] / "results" / "cpu" / "navigation" / "checkpoints"


def test_paths_are_compared_point_by_point_along_their_length():
    line = np.stack([np.linspace(0, 1, 11), np.zeros(11)], axis=1)
    assert path_distance(line, line + [0.0, 0.3]) == pytest.approx(0.3)  # a parallel line 0.3 m away
    slow = np.stack([np.linspace(0, 1, 101) ** 2, np.zeros(101)], axis=1)  # the same line, unevenly sampled
    assert path_distance(line, slow) == pytest.approx(0.0, abs=1e-9)
    assert resampled(np.zeros((5, 2)), 7).shape == (7, 2)  # a robot that never moved


def _records(task, planning, sets, *, films=True):
    out, cache = [], {}
    for style in (LEGIBLE, EFFICIENT):
        planner = load_method(style if films else "scdp:none", CKPT, task, planning)
        labelled = [(name, i, scene) for name, scenes in sets.items() for i, scene in enumerate(scenes)]
        runs = rollout(task, planner, [s for *_, s in labelled], seeds=list(range(len(labelled))))
        out += [score_rollout(task, r, method=style, scene_set=n, scene_index=i, bounds=scene_bounds(task, r.goals, r.target, cache))
                for (n, i, _), r in zip(labelled, runs)]
    return out


def test_the_full_planner_keeps_its_style_and_one_without_films_does_not():
    task = get_task("navigation")
    sets = {k: v for k, v in scene_sets(task, 4, 79, stream=VALIDATION).items() if k in (AMBIGUOUS, CLEAR)}
    realtime = PlanningOptions(sampler="ddpm", steps=8, warm_skip=4)
    full = _records(task, realtime, sets)
    same = fidelity(full, full)
    assert same["keeps_style"] and same["gap_share"] == pytest.approx(1.0) and same["path_distance"]["mean"] == 0.0
    assert same["d_hat_gap"]["mean"] == 0.0 and same["observer_gap"]["mean"] == 0.0
    off = fidelity(full, _records(task, realtime, sets, films=False))
    assert off["gap_share"] == 0.0 and not off["keeps_style"]  # both styles plan one path: no gap at all
    assert off["path_distance"]["mean"] > 0.01 and off["d_hat_gap"]["mean"] < 0


def test_the_rule_needs_both_the_gap_and_the_observer():
    observer = PairedDifference("candidate", "full", "observer_gap", 100, 100, 0.0, -0.05, 0.05)
    assert keeps_style(0.95, observer)
    assert not keeps_style(0.85, observer)  # lost more than a tenth of the D̂ gap
    assert not keeps_style(float("nan"), observer)  # the full planner had no gap to keep
    assert not keeps_style(0.95, PairedDifference("candidate", "full", "observer_gap", 100, 100, -0.1, -0.2, 0.0))
