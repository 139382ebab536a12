"""Bootstrap by resampling weights, for data with more than one source of variation (a study's
participants and scenes), beside :mod:`scdp.evaluation.statistics`' scene bootstraps.

A resample is a weight per observation: how many times its cluster was drawn. Draws of several
crossed factors multiply (participants x scenes: :func:`crossed_weights`), and any weighted statistic
of a resample is a row of weights times the values (:func:`weighted_means`); the interval is the
percentiles of the resampled statistics (:func:`percentile_interval`).
"""

from __future__ import annotations

import numpy as np


def cluster_draws(n: int, samples: int, rng: np.random.Generator) -> np.ndarray:
    """(samples, n) counts: each resample draws ``n`` of ``n`` clusters with replacement."""
    return np.stack([np.bincount(rng.integers(0, n, n), minlength=n) for _ in range(samples)])


def crossed_weights(participants: np.ndarray, scenes: np.ndarray, samples: int, seed: int) -> np.ndarray:
    """(samples, N) bootstrap weights of N responses: participants and scenes each resampled with
    replacement, a response weighted by (times its participant drawn) x (times its scene drawn)."""
    rng = np.random.default_rng(seed)
    p_ids, p_of = np.unique(participants, return_inverse=True)
    s_ids, s_of = np.unique(scenes, return_inverse=True)
    wp = cluster_draws(len(p_ids), samples, rng)
    ws = cluster_draws(len(s_ids), samples, rng)
    return (wp[:, p_of] * ws[:, s_of]).astype(np.float64)


def weighted_means(weights: np.ndarray, values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Per bootstrap sample, the weighted mean of ``values`` (N,) or (N, G) over the masked responses."""
    w = weights[:, mask]
    total = w.sum(axis=1)
    total[total == 0] = np.nan  # a resample that drew none of these responses
    return (w @ values[mask]) / (total[:, None] if values.ndim == 2 else total)


def percentile_interval(draws: np.ndarray) -> list[float]:
    """The 95 % percentile interval of bootstrap ``draws`` (samples,), resamples drawing none left out."""
    return [float(np.nanpercentile(draws, 2.5, axis=0)), float(np.nanpercentile(draws, 97.5, axis=0))]
