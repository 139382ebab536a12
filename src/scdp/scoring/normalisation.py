"""Two readings of D̂, Ê and ĵ: per scene (ours) and over the training data (the paper's wording).

T = (1 − w(ĵ)) D̂ + w(ĵ) Ê needs D and E brought to a common scale, and the paper says only that
they are min-max normalised "with respect to the values obtained from the training dataset". Two
readings are defensible, and scdp reports every verdict under both (:data:`NORMALISATIONS`):

* ``scene`` (the default, every stored record): D and E min-max over the scene's own reference
  set (:func:`scdp.scoring.score.reference_bounds`), ĵ over the task's range
  (:func:`scdp.scoring.score.j_hat`). A method difference is read against what the scene allows.
* ``dataset``: D and E min-max over the task's training demonstrations (each demonstration's D
  and E under the same conventions: :func:`scdp.scoring.score.raw_scores` of its path), ĵ over the
  smallest and largest j of the training scenes (clipped to [0, 1]). The range of D over a
  random-scene dataset is many times a single scene's, so scene geometry dominates D̂ and Ê and
  method differences shrink. Where demonstrations come from one fixed layout (the authors'
  per-layout protocol) the two readings nearly coincide.

Both are computed from the raw D and E a record stores, so switching re-scores and never
re-trains or re-plans (:func:`normalise`). :class:`DatasetRange` is the range of one training
set, stored beside its demonstrations and in ``results.json``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from scdp import metrics
from scdp.errors import ScdpError
from scdp.keys import DATASET_NORMALISATION as DATASET
from scdp.keys import NORMALISATIONS
from scdp.keys import SCENE_NORMALISATION as SCENE
from scdp.scoring.reference import MIN_SPAN
from scdp.scoring.score import raw_scores
from scdp.tasks import Task

NAMES = {SCENE: "per scene (scdp)", DATASET: "over the training data (the paper's wording)"}


@dataclass(frozen=True)
class DatasetRange:
    """Min-max of D, E and j over a training set of ``demos`` demonstrations (``fingerprint``: theirs)."""

    d_min: float
    d_max: float
    e_min: float
    e_max: float
    j_min: float
    j_max: float
    demos: int
    fingerprint: str = ""

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d, field: str = "normalisation") -> DatasetRange:
        """Read a stored range, refusing one that is incomplete or whose spans collapse."""
        names = [f.name for f in fields(cls)]
        if not isinstance(d, dict) or any(k not in d for k in names[:-1]):
            raise ScdpError(field, f"not a dataset range (expected the keys {', '.join(names[:-1])})")
        try:
            rng = cls(**{k: (str(d[k]) if k == "fingerprint" else int(d[k]) if k == "demos" else float(d[k]))
                         for k in names if k in d})
        except (TypeError, ValueError) as exc:
            raise ScdpError(field, f"not a dataset range ({exc})") from None
        for name in ("d", "e", "j"):  # j may not span: one layout's demos all share one j (normalise says what then)
            lo, hi = getattr(rng, f"{name}_min"), getattr(rng, f"{name}_max")
            if not (math.isfinite(lo) and math.isfinite(hi) and (hi - lo >= MIN_SPAN or (name == "j" and hi >= lo))):
                raise ScdpError(field, f"{name}_min {lo!r} and {name}_max {hi!r} do not span a range")
        return rng


def dataset_range(task: Task, dataset) -> DatasetRange:
    """The range of D, E and j over a :class:`~scdp.data.dataset.DemoDataset`'s demonstrations: each
    episode's path scored in its own scene as a rollout is (:func:`~scdp.scoring.score.raw_scores`)."""
    rows = []
    for i in range(dataset.num_episodes):
        ep = dataset.episode(i)
        D, E = raw_scores(task, task.episode_path(ep), ep["goals"], ep["target"])
        rows.append((D, E, metrics.goal_separation(ep["goals"], ep["target"])))
    if not rows:
        raise ScdpError("demos", "the dataset holds no demonstrations to take a range from")
    a = np.asarray(rows, dtype=np.float64)
    lo, hi = a.min(axis=0), a.max(axis=0)
    return DatasetRange.from_dict({"d_min": lo[0], "d_max": hi[0], "e_min": lo[1], "e_max": hi[1], "j_min": lo[2],
                                   "j_max": hi[2], "demos": len(rows), "fingerprint": dataset.fingerprint()}, "demos")


def normalise(D: float, E: float, goals, target: int, rng: DatasetRange) -> tuple[float, float, float]:
    """(D̂, Ê, ĵ) of raw D and E in a scene under the ``dataset`` reading: D and E min-max over ``rng``
    (not clipped, as per scene), ĵ over its j range, clipped to [0, 1]. Where the training scenes share
    one j (a per-layout model set: one goal pair), there is no range to normalise over and ĵ is 0.5,
    the midpoint, so T weighs D̂ and Ê equally."""
    j = metrics.goal_separation(goals, target)
    if rng.j_max - rng.j_min < MIN_SPAN:
        return (float(metrics.min_max(D, rng.d_min, rng.d_max)), float(metrics.min_max(E, rng.e_min, rng.e_max)), 0.5)
    return (float(metrics.min_max(D, rng.d_min, rng.d_max)), float(metrics.min_max(E, rng.e_min, rng.e_max)),
            float(np.clip(metrics.normalised_goal_separation(j, rng.j_min, rng.j_max), 0.0, 1.0)))


def check_normalisation(name: str, field: str = "--normalisation") -> str:
    if name not in NORMALISATIONS:
        raise ScdpError(field, f"unknown normalisation {name!r} (choose from {', '.join(NORMALISATIONS)})")
    return name
