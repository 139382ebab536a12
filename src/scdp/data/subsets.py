"""Style subsets: the most legible and the most efficient demonstrations.

Scenes differ, so raw D and E are not comparable across demos. Each demo is scored
against its own scene's reference set (:mod:`scdp.data.reference`): ``d_hat`` ranks legibility,
``e_hat`` ranks efficiency. The top ``fraction`` of demos by that score forms the subset.
"""

from __future__ import annotations

import numpy as np

from scdp.data.reference import normalised_scores, reference_bounds
from scdp.errors import ScdpError
from scdp.keys import STYLES
from scdp.tasks import get_task


def episode_scores(dataset, references: int = 100) -> np.ndarray:
    """(E, 2) array of per-scene normalised (d_hat, e_hat) for every episode."""
    task = get_task(dataset.task)
    out = np.empty((dataset.num_episodes, 2))
    for i in range(dataset.num_episodes):
        ep = dataset.episode(i)
        bounds = reference_bounds(task, ep["goals"], ep["target"], n=references)
        out[i] = normalised_scores(task, task.episode_path(ep), ep["goals"], ep["target"], bounds)
    return out


def style_subset(dataset, style: str = "legible", fraction: float = 0.2, *, references: int = 100):
    """The top ``fraction`` of episodes by per-scene normalised detachment ("legible") or
    efficiency ("efficient"), as a new :class:`~scdp.data.dataset.DemoDataset`.
    """
    if style not in STYLES:
        raise ScdpError("style", f"unknown style {style!r} (choose from {', '.join(STYLES)})")
    if not 0.0 < fraction <= 1.0:
        raise ScdpError("fraction", f"must lie in (0, 1], got {fraction}")
    scores = episode_scores(dataset, references)[:, 0 if style == "legible" else 1]
    k = max(1, int(round(fraction * dataset.num_episodes)))
    order = np.argsort(-scores, kind="stable")[:k]
    sub = dataset.subset(order)
    sub.attrs.update(style=style, fraction=fraction, score="d_hat" if style == "legible" else "e_hat")
    return sub
