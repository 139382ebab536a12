"""Scoring paths against per-scene reference curves: D, E, their normalised D̂ and Ê, ĵ and T.

A layer above :mod:`scdp.data` (whose Bézier generator draws the reference curves) and below
:mod:`scdp.models`. The paper min-max normalises D and E "with respect to the training dataset".
Since every scene differs, we normalise each scene against a *reference set* generated for that
scene on demand: ``n`` Bézier paths from the task's nominal start to g*, drawn with the same
control-point distribution as the demonstration generator (seeded, so the bounds of a scene are
reproducible).

Reference paths are the generator's task-space Bézier curves, not simulated executions,
which makes hundreds of scenes cheap. ``benchmarks/reference_fidelity.py`` shows that D and
E of these curves match those of the executed demonstrations closely.

Conventions (as the authors did, plus REFERENCE §6):

* Every path — reference or rollout — is first cut at its first point inside the success
  radius, so a rollout that stops on entering the radius is compared like with like.
* D is computed on the cut path resampled to 200 points linearly in time; E on the cut
  path as it is. Dragan legibility uses the same 200-point path.
* ``d_hat = (D - d_min) / (d_max - d_min)`` and likewise E; not clipped.
* ``j_hat`` is the goal distance min-max normalised over the task's range
  ``[min_goal_separation, diagonal of the goal sampling box]``, clipped to [0, 1].

Three modules, bottom up:

* :mod:`~scdp.scoring.reference`: the reference set of a scene (:func:`reference_paths`) and the
  :class:`Bounds` of D and E over it;
* :mod:`~scdp.scoring.score`: scoring one path: D and E (:func:`raw_scores`, on the path
  :func:`cut_at_goal`), the scene's :func:`reference_bounds`, :func:`normalised_scores`,
  :func:`j_hat`, and :func:`score_path` for every metric at once;
* :mod:`~scdp.scoring.normalisation`: the two readings of D̂, Ê and ĵ, per scene (the above) and
  over the training data (the paper's wording: :class:`DatasetRange`, :func:`dataset_range`,
  :func:`normalise`), every verdict reported under both;
* :mod:`~scdp.scoring.subsets`: the demonstrations ranked by these scores into the style
  subsets (:func:`style_subset`, :func:`subset_gaps`).

Every public name is re-exported here (``from scdp.scoring import score_path``).
"""

from __future__ import annotations

from scdp.scoring.normalisation import NAMES as NORMALISATION_NAMES
from scdp.scoring.normalisation import DatasetRange, check_normalisation, dataset_range, normalise
from scdp.scoring.reference import DEFAULT_REFERENCES, MIN_SPAN, Bounds, goal_families, reference_paths
from scdp.scoring.score import (
                                RESAMPLE_POINTS,
                                cut_at_goal,
                                j_hat,
                                normalised_scores,
                                observed_path,
                                raw_scores,
                                reference_bounds,
                                score_path,
)
from scdp.scoring.subsets import PAPER_SCORE, SCORES, ambiguous_at_start, episode_scores, style_subset, subset_gaps, top_fraction

__all__ = ["DEFAULT_REFERENCES", "MIN_SPAN", "NORMALISATION_NAMES", "PAPER_SCORE", "DatasetRange", "check_normalisation",
           "dataset_range", "normalise", "RESAMPLE_POINTS", "SCORES", "Bounds", "ambiguous_at_start",
           "cut_at_goal", "episode_scores", "goal_families", "j_hat", "normalised_scores", "observed_path", "raw_scores",
           "reference_bounds", "reference_paths", "score_path", "style_subset", "subset_gaps", "top_fraction"]
