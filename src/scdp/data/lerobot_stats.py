"""LeRobot's feature statistics: per episode, and pooled over a dataset, as LeRobot (v3) computes them.

LeRobot keeps, for every non-string feature and every dimension: ``min``, ``max``, ``mean``, ``std`` (the
population one), ``count`` (frames, as a one-element list) and the quantiles ``q01``, ``q10``, ``q50``,
``q90``, ``q99``. Per episode they go in ``meta/episodes`` (columns ``stats/<feature>/<stat>``); pooled over the
dataset, in ``meta/stats.json``. LeRobot's tools rebuild ``stats.json`` from the per-episode columns after an
edit (``delete_episodes``, ``merge_datasets``), and normalisation by quantiles (pi0.5's default) reads
``q01`` and ``q99``.

The quantiles are LeRobot's, not :func:`numpy.quantile`: per episode, the values of each dimension are
counted in :data:`QUANTILE_BINS` equal bins between their min and max, and the quantile is interpolated
linearly inside the bin where the cumulative count reaches ``q * count``; pooled, each is the
count-weighted mean of the episodes' quantiles. So a dataset scdp writes and one LeRobot writes from the same
frames carry the same numbers.
"""

from __future__ import annotations

import numpy as np

QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)
QUANTILE_BINS = 5000
EDGE_PAD = 1e-10  # the bins reach this far beyond the min and max, so both fall inside them
STAT_KEYS = ("min", "max", "mean", "std", "count", *(f"q{round(q * 100):02d}" for q in QUANTILES))


def _quantiles(column: np.ndarray) -> list[float]:
    """:data:`QUANTILES` of one dimension's values (n,) by the binned interpolation of the module docstring."""
    lo, hi = float(column.min()) - EDGE_PAD, float(column.max()) + EDGE_PAD
    counts, edges = np.histogram(column, bins=QUANTILE_BINS, range=(lo, hi))
    cumulative = np.cumsum(counts)
    out = []
    for q in QUANTILES:
        want = q * len(column)
        b = int(np.searchsorted(cumulative, want))  # the first bin whose cumulative count reaches it
        if b >= QUANTILE_BINS:
            out.append(float(edges[-1]))
            continue
        before = cumulative[b - 1] if b > 0 else 0
        inside = (want - before) / counts[b] if counts[b] else 0.0
        out.append(float(edges[b] + inside * (edges[b + 1] - edges[b])))
    return out


def feature_stats(values) -> dict[str, np.ndarray]:
    """The statistics of one feature over one episode's frames, ``values`` (n, d) or (n,): each (d,), count (1,)."""
    v = np.asarray(values)
    v = v.reshape(len(v), -1)
    as_float = v.astype(np.float64)
    mean = as_float.mean(0)
    out = {"min": v.min(0), "max": v.max(0), "mean": mean,
           "std": np.sqrt(np.maximum((as_float**2).mean(0) - mean**2, 0.0)), "count": np.array([len(v)])}
    if len(v) < 2:  # nothing to bin: every quantile is the value itself
        quantiles = np.repeat(mean[None], len(QUANTILES), axis=0)
    else:
        quantiles = np.array([_quantiles(as_float[:, j]) for j in range(v.shape[1])]).T  # (Q, d)
    out.update({key: quantiles[i] for i, key in enumerate(STAT_KEYS[5:])})
    return out


def pooled_stats(episodes: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """One feature's statistics over a dataset from its episodes' (:func:`feature_stats`): min and max of all,
    the count-weighted mean, the pooled population std, the summed count, count-weighted quantiles."""
    counts = np.array([float(e["count"][0]) for e in episodes])
    weights = counts / counts.sum()
    means = np.stack([e["mean"] for e in episodes])
    mean = weights @ means
    variance = weights @ (np.stack([e["std"] for e in episodes]) ** 2 + (means - mean) ** 2)
    out = {"min": np.min([e["min"] for e in episodes], axis=0), "max": np.max([e["max"] for e in episodes], axis=0),
           "mean": mean, "std": np.sqrt(variance), "count": np.array([int(counts.sum())])}
    out.update({key: weights @ np.stack([e[key] for e in episodes]) for key in STAT_KEYS[5:]})
    return out


def as_json(stats: dict[str, np.ndarray]) -> dict[str, list]:
    """Statistics as ``stats.json`` holds them: lists, integers where the feature is."""
    return {key: np.asarray(value).tolist() for key, value in stats.items()}
