"""scdp.scoring: a scene's reference set, D, E, T of a path, and the style subsets ranked by them."""

import numpy as np
import pytest

from scdp import scoring
from scdp.data.bezier import demo_path, demo_paths, sample_by_arc_length
from scdp.errors import ScdpError
from scdp.scoring import style_subset
from scdp.scoring.score import raw_scores, raw_scores_many
from scdp.tasks import BLOCK_REACH, get_task


def test_reference_paths_score_like_executed_demos(small_datasets, task):
    """The cheap Bézier references stand in for executed demos: D and E agree closely."""
    ds = small_datasets[task.name]
    cps = np.asarray(ds.attrs["control_points"])
    for i in range(ds.num_episodes):
        ep = ds.episode(i)
        executed = task.episode_path(ep)
        g = ep["goals"][ep["target"]]
        planned = sample_by_arc_length(executed[0], cps[i], g, task.step_size)
        D1, E1 = scoring.raw_scores(task, executed, ep["goals"], ep["target"])
        D0, E0 = scoring.raw_scores(task, planned, ep["goals"], ep["target"])
        assert D1 == pytest.approx(D0, rel=0.03)
        assert E1 == pytest.approx(E0, rel=0.03)


def test_bounds_order_and_reproducibility(task):
    goals = task.layouts[0]
    b = scoring.reference_bounds(task, goals, 0, n=30, seed=1)
    assert b.d_min < b.d_max and b.e_min < b.e_max
    assert b == scoring.reference_bounds(task, goals, 0, n=30, seed=1)


def test_straight_path_is_the_most_efficient_reference(task):
    goals = task.layouts[3]
    b = scoring.reference_bounds(task, goals, 0, n=50)
    straight = np.linspace(task.start_point, goals[0], 100)
    s = scoring.score_path(task, straight, goals, 0, b)
    assert s["e_hat"] >= 0.95
    assert s["success"]


def test_j_hat_range(task):
    lo, hi = task.goal_distance_range()
    g = task.layouts[0].copy()
    assert scoring.j_hat(task, g, 0) == pytest.approx((np.linalg.norm(g[0] - g[1]) - lo) / (hi - lo))
    assert 0.0 <= scoring.j_hat(task, task.layouts[4], 1) <= 1.0


def test_style_subsets_rank_as_promised(small_datasets):
    ds = small_datasets["navigation"]
    legible = style_subset(ds, "legible", fraction=0.25, references=30)
    efficient = style_subset(ds, "efficient", fraction=0.25, references=30)
    assert legible.num_episodes == efficient.num_episodes == 3
    from scdp.scoring import episode_scores

    leg, eff = episode_scores(legible, 30), episode_scores(efficient, 30)
    everything = episode_scores(ds, 30)
    assert leg[:, 0].min() >= np.sort(everything[:, 0])[-3] - 1e-9  # top-3 by d_hat
    assert eff[:, 1].min() >= np.sort(everything[:, 1])[-3] - 1e-9  # top-3 by e_hat
    assert leg[:, 0].mean() > eff[:, 0].mean()
    assert eff[:, 1].mean() > leg[:, 1].mean()


def test_an_efficient_subset_ranked_by_t_keeps_the_top_t_demos(small_datasets):
    from scdp.scoring import SCORES, episode_scores

    ds = small_datasets["navigation"]
    everything = episode_scores(ds, 30)
    t = everything[:, SCORES.index("transparency")]
    by_t = style_subset(ds, "efficient", fraction=0.25, references=30, score="transparency")
    kept = episode_scores(by_t, 30)[:, SCORES.index("transparency")]
    assert by_t.attrs["score"] == "transparency"
    np.testing.assert_allclose(np.sort(kept), np.sort(t)[-3:])
    # T lies between D̂ and Ê demo by demo (it is their convex combination, eq. 7)
    lo, hi = np.minimum(everything[:, 0], everything[:, 1]), np.maximum(everything[:, 0], everything[:, 1])
    assert np.all((t >= lo - 1e-12) & (t <= hi + 1e-12))


def test_style_subset_rejects_bad_arguments(small_datasets):
    with pytest.raises(ScdpError, match="style"):
        style_subset(small_datasets["navigation"], "bold")
    with pytest.raises(ScdpError, match="fraction"):
        style_subset(small_datasets["navigation"], "legible", fraction=0.0)
    with pytest.raises(ScdpError, match="score"):
        style_subset(small_datasets["navigation"], "efficient", score="speed")


@pytest.mark.parametrize("score, viewpoint", [("legibility", False), ("viewpoint_legibility", True)])
def test_a_legible_subset_ranked_by_an_observer_keeps_the_demos_that_observer_reads_best(small_datasets, score, viewpoint):
    """On Block Reach, the observer rankings keep the top demos by their legibility normalised over
    the scene's references (recomputed here by hand from :func:`path_legibility`), and the two
    rankings differ (the viewer across the table does not see what the task-space observer sees)."""
    from scdp.scoring.subsets import observer_legibility, path_legibility

    ds = small_datasets["block_reach"]
    task = BLOCK_REACH
    by_hand = []
    for i in range(ds.num_episodes):
        ep = ds.episode(i)
        refs = [path_legibility(task, p, ep["goals"], ep["target"], viewpoint)
                for p in scoring.reference_paths(task, ep["goals"], ep["target"], 30)]
        own = path_legibility(task, task.episode_path(ep), ep["goals"], ep["target"], viewpoint)
        by_hand.append((own - min(refs)) / (max(refs) - min(refs)))
    ranked = observer_legibility(ds, viewpoint, references=30)
    np.testing.assert_allclose(ranked, by_hand)
    subset = style_subset(ds, "legible", fraction=0.25, references=30, score=score)
    assert subset.attrs["score"] == score and subset.num_episodes == 3
    np.testing.assert_allclose(np.sort(observer_legibility(subset, viewpoint, references=30)), np.sort(by_hand)[-3:])
    assert not np.allclose(ranked, observer_legibility(ds, not viewpoint, references=30))


def test_the_viewpoint_legibility_of_a_motion_along_the_line_of_sight_is_chance():
    """Two blocks on one line of sight from the Block Reach viewer: seen from there, every point of
    the path is as close to one as to the other, so the observer's belief stays 1/2 (chance)."""
    from scdp.scoring.subsets import path_legibility
    from scdp.tasks import BLOCK_REACH

    eye = np.array(BLOCK_REACH.viewer_eye)
    near = np.array([0.6, 0.0, 0.1])
    goals = np.array([near, eye + 1.3 * (near - eye)])
    path = np.linspace([0.3, 0.0, 0.5], near, 80)
    assert path_legibility(BLOCK_REACH, path, goals, 0, viewpoint=True) == pytest.approx(0.5, abs=1e-9)
    assert path_legibility(BLOCK_REACH, path, goals, 0) > 0.55  # in task space the far block is elsewhere


@pytest.mark.parametrize("task_name", ["navigation", "block_reach"])
def test_the_reference_set_drawn_at_once_is_the_one_drawn_path_by_path(task_name):
    """reference_bounds samples its 100 curves and scores them in one pass: each path and each D and E
    is the value the one-at-a-time loop gives, to the bit."""
    task = get_task(task_name)
    goals = task.sample_goals(np.random.default_rng(7), 3)
    one, many = np.random.default_rng(2), np.random.default_rng(2)
    singly = [demo_path(task, one, task.start_point, goals[1])[0] for _ in range(40)]
    together = demo_paths(task, many, task.start_point, goals[1], 40)
    assert all(a.shape == b.shape and np.array_equal(a, b) for a, b in zip(singly, together))
    assert one.random() == many.random()  # the stream is left where the loop leaves it
    scores = raw_scores_many(task, together, goals, 1)
    assert np.array_equal(scores, np.array([raw_scores(task, p, goals, 1) for p in singly]))
