"""The legible rankings that ask for detachment and legibility together (scdp.scoring.subsets)."""

import numpy as np
import pytest

from scdp.config import StyleSection
from scdp.errors import ScdpError
from scdp.scoring import subsets
from scdp.scoring.subsets import JOINT_SCORES, joint_ranking, normalised_ranks, pareto_fronts, top_fraction

# demo 0 is the most detached, demo 3 the most legible; demo 1 is second on both, demo 2 third on both
D_HAT = np.array([1.0, 0.8, 0.7, 0.1])
LEGIBILITY = np.array([0.1, 0.8, 0.7, 1.0])


def test_ranks_are_scaled_to_one_and_ties_share_their_mean():
    assert normalised_ranks([3.0, 1.0, 2.0, 2.0]).tolist() == [1.0, 0.0, 0.5, 0.5]
    assert normalised_ranks([5.0]).tolist() == [1.0]


def test_fronts_peel_the_rows_nothing_beats_on_both():
    assert pareto_fronts(np.column_stack([D_HAT, LEGIBILITY])).tolist() == [0, 0, 1, 0]
    assert pareto_fronts(np.array([[1.0, 1.0], [1.0, 1.0], [0.0, 0.0]])).tolist() == [0, 0, 1]  # equal rows: one front


@pytest.mark.parametrize("score", JOINT_SCORES)
def test_a_joint_ranking_keeps_the_demo_good_on_both_not_the_best_on_one(score):
    best = top_fraction(joint_ranking(D_HAT, LEGIBILITY, score), 0.25)
    assert best.tolist() == [1]
    assert top_fraction(D_HAT, 0.25).tolist() == [0] and top_fraction(LEGIBILITY, 0.25).tolist() == [3]  # one criterion


def test_pareto_fills_the_fraction_front_by_front():
    """Demo 2 is beaten by demo 1 on both: it is kept only after every demo of the first front."""
    order = np.argsort(-joint_ranking(D_HAT, LEGIBILITY, "pareto"), kind="stable")
    assert order[-1] == 2 and set(order[:3]) == {0, 1, 3}


class Demos:
    """Just enough of a DemoDataset for style_subset: which episodes it kept."""

    num_episodes = 4

    def subset(self, indices):
        self.kept, self.attrs = list(indices), {}
        return self


@pytest.mark.parametrize("score", JOINT_SCORES)
def test_the_style_subset_reads_both_scores_for_a_joint_ranking(score, monkeypatch):
    monkeypatch.setattr(subsets, "episode_scores", lambda dataset, references: np.column_stack([D_HAT, D_HAT, D_HAT]))
    monkeypatch.setattr(subsets, "observer_legibility", lambda dataset, viewpoint, references: LEGIBILITY)
    kept = subsets.style_subset(Demos(), "legible", 0.25, score=score)
    assert kept.kept == [1] and kept.attrs["score"] == score


def test_a_preset_takes_the_joint_rankings_and_refuses_others():
    for score in JOINT_SCORES:
        assert StyleSection(legible_score=score).legible_score == score
    with pytest.raises(ScdpError, match="legible_score"):
        StyleSection(legible_score="pareto_front")
