"""The method works: the paper's mechanisms checked on a small competent model set.

``scdp reproduce --task navigation --preset ci`` (the cpu preset's structure at an eighth of its
size: a couple of minutes on 2 cores) is trained once per session and rolled out on 20 ambiguous
and 20 clear random scenes of the evaluation stream, every method on the same scenes and noise.
The margins are far below what the trained nets reach (noted beside each) and far above what an
untrained or disabled mechanism gives.

How each assertion was shown to fail with its mechanism removed: ``tests/helpers/disable_mechanisms.py``
re-runs the fixture's evaluation (same checkpoints, scenes and noise) with one mechanism switched
off at planning time, and this file was run on its output (``SCDP_CI_RUN=<folder>``):

* ``untrained``: DP's network re-initialised: success 2 of 40 -> ``test_dp_reaches_its_goals`` fails;
* ``films``: identity films (γ = 1, β = 0 from every style predictor): the forced styles plan the
  same chunks, paired D̂ gap exactly 0.000 on both sets -> the forced-style test fails;
* ``arbitration``: ``scdp`` always efficient: no ambiguous scene starts legible -> the arbitration test fails;
* ``guidance``: LD with w₀ = 0 (its unguided base): D̂(ld) − D̂(dp) −0.002 ambiguous, +0.077 clear
  (guided: +0.203, +0.443) -> the LD test fails.
"""

import numpy as np
import pytest

from scdp.evaluation.records import load_records
from scdp.evaluation.statistics import compare, paired_scenes
from scdp.keys import AMBIGUOUS, CLEAR

SETS = (AMBIGUOUS, CLEAR)
# The first test here trains the session's model set (conftest.competent_navigation) in its setup.
# On one 2-core machine (matmul peak 87 GFLOP/s) that took 330 s in a fresh-clone suite, 710 s under
# the portable kernels (ATEN_CPU_CAPABILITY=default: the suite's 600 s per test cut it off), and
# 13.4 min as one standalone `reproduce --preset ci`; 2400 s leaves room for twice the slowest.
pytestmark = pytest.mark.timeout(2400)


@pytest.fixture(scope="module")
def records(competent_navigation):
    return [r for r in load_records(competent_navigation / "results.json") if r.scene_set in SETS]


def of(records, method, scene_set=None):
    return [r for r in records if r.method == method and (scene_set is None or r.scene_set == scene_set)]


def d_hat_gap(records, a, b, scene_set):
    gaps, _ = paired_scenes([r for r in records if r.scene_set == scene_set], a, b, lambda r: r.metrics["d_hat"])
    return gaps


def test_every_method_ran_on_the_same_scenes(records):
    for scene_set in SETS:
        scenes = {m: sorted(r.scene_index for r in of(records, m, scene_set)) for m in ("dp", "ld", "scdp", "scdp_legible")}
        assert len(scenes["dp"]) == 20 and all(v == scenes["dp"] for v in scenes.values())


def test_dp_reaches_its_goals(records):
    """Trained: 40 of 40. Untrained (tiny preset): 3 of 16."""
    runs = of(records, "dp")
    assert np.mean([r.success for r in runs]) >= 0.9, [r.success for r in runs]
    assert np.mean([r.success for r in of(records, "scdp")]) >= 0.85


def test_the_forced_legible_style_is_more_detached_than_the_efficient_one(records):
    """Paired D̂(scdp_legible) − D̂(scdp_efficient), same scenes and noise. Trained: +0.13 on ambiguous,
    +0.47 on clear scenes. Identity films: exactly 0 on both."""
    ambiguous, clear = (d_hat_gap(records, "scdp_legible", "scdp_efficient", s) for s in SETS)
    assert ambiguous.mean() >= 0.07, ambiguous.mean()
    assert clear.mean() >= 0.2, clear.mean()
    c = compare([r for r in records if r.scene_set == CLEAR], "scdp_legible", "scdp_efficient", "d_hat")
    assert c.lo > 0, c  # clearly: the interval excludes zero


def test_scdp_picks_legible_only_where_the_scene_is_ambiguous(records):
    """The first chunk is planned at the start, where the scene sets are split by eq. 3. Trained: every
    ambiguous scene starts legible, no clear scene plans a legible chunk. "Always efficient": 0 %."""
    first = {s: np.mean([r.styles[0] == "legible" for r in of(records, "scdp", s)]) for s in SETS}
    any_legible_clear = np.mean(["legible" in r.styles for r in of(records, "scdp", CLEAR)])
    assert first[AMBIGUOUS] >= 0.9 and first[CLEAR] <= 0.1 and any_legible_clear <= 0.1, (first, any_legible_clear)
    switched = np.mean([r.styles[-1] == "efficient" for r in of(records, "scdp", AMBIGUOUS) if len(r.styles) > 3])
    assert switched >= 0.5  # once the target is clear of the distractor, the style goes back to efficient


def test_ld_guidance_moves_paths_away_from_the_distractor(records):
    """Paired D̂(ld) − D̂(dp). Trained with the cpu preset's guidance (w₀ = 18): +0.20 on ambiguous, +0.44
    on clear scenes."""
    ambiguous, clear = (d_hat_gap(records, "ld", "dp", s) for s in SETS)
    assert ambiguous.mean() >= 0.1 and clear.mean() >= 0.2, (ambiguous.mean(), clear.mean())
