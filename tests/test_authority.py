"""Style authority along the motion (scdp.evaluation.authority): a switch changes nothing before it and the rest of
the motion after it, on the tiny run's SCDP."""

import numpy as np

from scdp.data.scenes import VALIDATION
from scdp.evaluation.authority import drive, scene_authority, separation, summarise
from scdp.evaluation.protocol import scene_sets
from scdp.keys import AMBIGUOUS
from scdp.policies.loaders import load_method
from scdp.tasks import get_task


def test_a_style_switch_keeps_the_path_before_it_and_moves_the_rest(tiny_reproduction):
    task = get_task("navigation")
    planner = load_method("scdp", tiny_reproduction / "navigation" / "checkpoints", task)
    goals, target = scene_sets(task, 1, 0, stream=VALIDATION)[AMBIGUOUS][0]
    held = drive(task, planner, goals, target, 3, "efficient")
    at = (len(held) - 1) // 3
    switched = drive(task, planner, goals, target, 3, "efficient", "legible", at)
    assert np.array_equal(switched[:at + 1], held[:at + 1])  # the same scene, noise and actions until the switch
    assert separation(switched, held, at) > 0  # ... and another motion after it
    assert np.array_equal(drive(task, planner, goals, target, 3, "efficient"), held)  # one seed, one motion
    records = scene_authority(task, planner, goals, target, 3, fractions=(0.0, 0.5))
    rows = summarise(records)
    assert [(r["first"], r["fraction"]) for r in rows] == [("efficient", 0.0), ("efficient", 0.5), ("legible", 0.0),
                                                           ("legible", 0.5)]
    assert all(r["separation_ratio"] == 1.0 for r in rows if r["fraction"] == 0.0)
    assert records[0]["separation"] == rows[0]["separation"] > 0  # one scene: its own median


def test_a_ratio_to_no_gain_at_the_start_is_no_number():
    """Two scenes whose observer gain at 0 cancels (+0.1, -0.1, as float sums leave it: 1e-17, not 0): the gain
    ratio is NaN, not a number of 1e16 (what rest_windows.md printed before), and the separation ratio stands."""
    rec = [{"first": "efficient", "fraction": f, "separation": s, "gain": g, "detour_switched": 1.0, "detour_unswitched": 1.0}
           for f, s, g in ((0.0, 0.2, 0.1 + 0.2 - 0.3 + 0.1), (0.0, 0.2, -0.1), (0.3, 0.05, 0.05), (0.3, 0.05, 0.0))]
    rows = summarise(rec)
    assert abs(rows[0]["gain"]) < 1e-9 and np.isnan(rows[1]["gain_ratio"]) and rows[1]["separation_ratio"] == 0.25
