"""Paired comparisons of methods: differences on the same scenes, with bootstrap intervals.

Every method is rolled out on the same scenes with the same per-scene noise, so the record of
method A and the record of method B for one scene form a pair. A claim "A beats B" holds only
when the 95 % bootstrap interval of the mean paired difference excludes zero in its direction.

Scenes, not records, are the independent units. Where several pairs share a scene (a layout's
``layout_repeats`` rollouts of one target, which differ only in noise; the same scene under the
models of several training seeds, :attr:`TrajectoryRecord.training_seed`), :func:`compare`
resamples scenes (:func:`cluster_bootstrap_interval`, clusters named by
:func:`scdp.evaluation.records.scene_key`, seeds and repeats nested inside); with one pair per
scene that is exactly the plain bootstrap of the pairs (:func:`bootstrap_interval`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from statistics import NormalDist

import numpy as np

from scdp.evaluation.records import TrajectoryRecord, record_value, scene_key
from scdp.keys import AMBIGUOUS_LAYOUTS, CLEAR_LAYOUTS, LAYOUT_IDS, layout_name
from scdp.tasks import get_task

BOOTSTRAP_SAMPLES = 10_000
MIN_STARRED = 5  # an interval from fewer pairs than this is never starred as excluding zero: too few to say


def _percentiles(means: np.ndarray, level: float) -> tuple[float, float]:
    tail = 100 * (1 - level) / 2
    return float(np.percentile(means, tail)), float(np.percentile(means, 100 - tail))


def bootstrap_interval(values, *, level: float = 0.95, samples: int = BOOTSTRAP_SAMPLES, seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``values`` (seeded, so reports are reproducible)."""
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        return float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    means = values[rng.integers(0, len(values), size=(samples, len(values)))].mean(axis=1)
    return _percentiles(means, level)


def cluster_ids(clusters) -> np.ndarray:
    """0-based cluster numbers of hashable cluster keys, in order of first appearance."""
    order: dict = {}
    return np.array([order.setdefault(c, len(order)) for c in clusters], dtype=np.int64)


def cluster_bootstrap_interval(values, clusters, *, level: float = 0.95, samples: int = BOOTSTRAP_SAMPLES,
                               seed: int = 0) -> tuple[float, float]:
    """Percentile interval of the mean of ``values`` when the clusters, not the values, are independent.

    ``clusters[i]`` is the (hashable) cluster of ``values[i]``. Each bootstrap sample draws as
    many clusters as there are, with replacement, and takes the mean over every value of the
    drawn clusters (a cluster drawn twice counts twice). With one value per cluster, in the
    order of the values, the draws are those of :func:`bootstrap_interval` with the same seed.
    """
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        return float("nan"), float("nan")
    ids = cluster_ids(clusters)
    if len(ids) != len(values):
        raise ValueError(f"{len(values)} values but {len(ids)} cluster keys")
    sums = np.bincount(ids, weights=values)
    counts = np.bincount(ids).astype(np.float64)
    rng = np.random.default_rng(seed)
    draws = rng.integers(0, len(sums), size=(samples, len(sums)))
    return _percentiles(sums[draws].sum(axis=1) / counts[draws].sum(axis=1), level)


def cluster_bootstrap_ratio(numerators, denominators, clusters, *, level: float = 0.95,
                            samples: int = BOOTSTRAP_SAMPLES, seed: int = 0) -> tuple[float, float, float]:
    """``sum(numerators) / sum(denominators)`` and its percentile interval, clusters resampled as in
    :func:`cluster_bootstrap_interval` (the same draws for the same seed). A sample whose denominator
    is 0 gives no ratio; the interval is taken over the others (NaN when none has one)."""
    num, den = np.asarray(numerators, dtype=np.float64), np.asarray(denominators, dtype=np.float64)
    if len(num) == 0:
        return float("nan"), float("nan"), float("nan")
    ids = cluster_ids(clusters)
    num_sums, den_sums = np.bincount(ids, weights=num), np.bincount(ids, weights=den)
    rng = np.random.default_rng(seed)
    draws = rng.integers(0, len(num_sums), size=(samples, len(num_sums)))
    top, bottom = num_sums[draws].sum(axis=1), den_sums[draws].sum(axis=1)
    ratios = top[bottom != 0] / bottom[bottom != 0]
    ratio = float(num.sum() / den.sum()) if den.sum() != 0 else float("nan")
    return (ratio, *_percentiles(ratios, level)) if len(ratios) else (ratio, float("nan"), float("nan"))


def wilson_interval(rate: float, n: float, level: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a proportion ``rate`` observed on ``n`` independent units."""
    if n <= 0:
        return float("nan"), float("nan")
    z = NormalDist().inv_cdf(0.5 + level / 2)
    centre = (rate + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * np.sqrt(rate * (1 - rate) / n + z * z / (4 * n * n))
    return float(max(0.0, centre - half)), float(min(1.0, centre + half))


def success_rate(records: list[TrajectoryRecord], level: float = 0.95) -> dict:
    """Success rate of some records with its 95 % Wilson interval, counted on *scenes*.

    The rate is the mean over records; the interval takes n = the number of distinct scenes
    (:func:`scene_key`), which is the number of records for random scene sets and is
    conservative for repeated layouts (their repeats count as one scene).
    """
    rate = float(np.mean([r.success for r in records])) if records else float("nan")
    scenes = len({scene_key(r, i) for i, r in enumerate(records)})
    lo, hi = wilson_interval(rate, scenes, level)
    return {"mean": rate, "lo": lo, "hi": hi, "n": len(records), "scenes": scenes}


def _key(r: TrajectoryRecord, position: int):
    return (r.task, r.protocol, r.scene_set, r.training_seed, r.scene_index if r.scene_index is not None else position)


def matched(records: list[TrajectoryRecord], methods, value) -> tuple[np.ndarray, list]:
    """``value`` of each of ``methods`` on every scene all of them ran: (n scenes, len(methods)), in the
    first method's scene order, and the scene (:func:`scene_key`) of each row.

    Records match by (task, protocol, scene set, training seed, scene index); records without a
    scene index (files written before it existed) match by their order within the set.
    """
    def index(method):
        out, seen = {}, {}
        for r in records:
            if r.method == method:
                group = (r.task, r.protocol, r.scene_set, r.training_seed)
                seen[group] = seen.get(group, -1) + 1
                out[_key(r, seen[group])] = (r, seen[group])
        return out

    indexed = [index(m) for m in methods]
    keys = [k for k in indexed[0] if all(k in other for other in indexed[1:])]
    values = np.array([[value(ix[k][0]) for ix in indexed] for k in keys], dtype=np.float64).reshape(len(keys), len(methods))
    return values, [scene_key(*indexed[0][k]) for k in keys]


def paired_scenes(records: list[TrajectoryRecord], a: str, b: str, value) -> tuple[np.ndarray, list]:
    """``value(record_a) - value(record_b)`` over every scene both methods ran (:func:`matched`), in
    scene order, and the scene (:func:`scene_key`) of each pair."""
    values, scenes = matched(records, (a, b), value)
    return values[:, 0] - values[:, 1], scenes


def paired(records: list[TrajectoryRecord], a: str, b: str, value) -> np.ndarray:
    """The paired differences of :func:`paired_scenes`, without their scenes."""
    return paired_scenes(records, a, b, value)[0]


def metric_of(name: str):
    """A record's value for a metric name (:func:`scdp.evaluation.records.record_value`): a key of
    ``metrics``, ``success`` (0/1) or the failure-aware ``transparency_fa``."""
    return lambda r: record_value(r, name)


@dataclass(frozen=True)
class PairedDifference:
    """The one shape of a paired difference ``a - b`` on ``metric``: its mean over ``n`` pairs from
    ``scenes`` distinct scenes, and the 95 % (or ``level``) bootstrap interval ``[lo, hi]``.
    ``left_out``: pairs dropped because a measure is undefined for one run (the changing-scene
    detour of a failed run), None where nothing can be. Made by :func:`compare_values` and
    :func:`difference_of`; written to JSON by :meth:`row`, read back by :meth:`from_row`."""

    a: str
    b: str
    metric: str
    n: int
    scenes: int
    mean: float
    lo: float
    hi: float
    left_out: int | None = None

    def holds(self, direction: str = ">") -> bool:
        """The interval excludes zero in the claimed direction (``>``: a above b; ``<``: a below b)."""
        return self.lo > 0 if direction == ">" else self.hi < 0

    @property
    def starred(self) -> bool:
        """Excludes zero, from at least :data:`MIN_STARRED` pairs: what a table marks with ``*``."""
        return (self.lo > 0 or self.hi < 0) and self.n >= MIN_STARRED

    def cell(self) -> str:
        """``+0.123 [+0.045, +0.201]``."""
        return f"{self.mean:+.3f} [{self.lo:+.3f}, {self.hi:+.3f}]"

    def row(self, **where) -> dict:
        """The JSON row: ``where`` (task, scene set, normalisation) first, then the fields."""
        out = {**where, **{f.name: getattr(self, f.name) for f in fields(self)}}
        if self.left_out is None:
            del out["left_out"]
        return out

    @classmethod
    def from_row(cls, row: dict) -> PairedDifference:
        """A row of :meth:`row` (its ``where`` keys ignored)."""
        return cls(**{f.name: row[f.name] for f in fields(cls) if f.name in row})


def difference_of(diffs, scenes, a: str, b: str, name: str, *, seed: int = 0, clustered: bool = True,
                  level: float = 0.95, left_out: int | None = None) -> PairedDifference:
    """The :class:`PairedDifference` of per-pair differences ``diffs`` with each pair's scene: the
    scene-clustered bootstrap where scenes repeat (and ``clustered``), else the plain one."""
    diffs = np.asarray(diffs, dtype=np.float64)
    n_scenes = len(set(scenes))
    if clustered and n_scenes < len(diffs):
        lo, hi = cluster_bootstrap_interval(diffs, scenes, seed=seed, level=level)
    else:
        lo, hi = bootstrap_interval(diffs, seed=seed, level=level)
    return PairedDifference(a, b, name, int(len(diffs)), n_scenes, float(diffs.mean()) if len(diffs) else float("nan"),
                            lo, hi, left_out)


def compare(records: list[TrajectoryRecord], a: str, b: str, metric: str, *, seed: int = 0,
            clustered: bool = True) -> PairedDifference:
    """Mean paired difference ``a - b`` of ``metric`` with its 95 % bootstrap interval, n pairs and
    the number of distinct scenes.

    With ``clustered`` (the default) and more pairs than scenes, the bootstrap resamples scenes
    (:func:`cluster_bootstrap_interval`); otherwise it resamples pairs (:func:`bootstrap_interval`,
    identical when every scene has one pair).
    """
    return compare_values(records, a, b, metric_of(metric), metric, seed=seed, clustered=clustered)


def compare_values(records: list[TrajectoryRecord], a: str, b: str, value, name: str, *, seed: int = 0,
                   clustered: bool = True, level: float = 0.95) -> PairedDifference:
    """:func:`compare` for any per-record ``value`` (named ``name``); a pair where either value is NaN
    (a measure that does not exist for that run) is left out, and ``n`` counts the pairs kept.
    ``level`` is the two-sided interval's coverage (0.90: each end a one-sided 95 % bound)."""
    diffs, scenes = paired_scenes(records, a, b, value)
    kept = np.isfinite(diffs)
    return difference_of(diffs[kept], [s for s, k in zip(scenes, kept) if k], a, b, name, seed=seed,
                         clustered=clustered, level=level)


def holds(comparison: PairedDifference | dict, direction: str = ">") -> bool:
    """The interval excludes zero in the claimed direction (``>``: a above b; ``<``: a below b); a
    committed JSON row is read as its :class:`PairedDifference`."""
    if isinstance(comparison, dict):
        comparison = PairedDifference.from_row(comparison)
    return comparison.holds(direction)


PAIRS = (("scdp", "dp"), ("scdp", "ld"), ("scdp", "ld_paper"), ("scdp", "scdp_paper"), ("scdp", "dataset"),
         ("scdp_blend", "dp"), ("scdp_legible", "scdp_efficient"))
PAIRED_METRICS = ("transparency", "transparency_fa", "d_hat", "e_hat")


def scene_set_members(task: str, scene_set: str) -> set[str]:
    """The scene sets a name covers: a layout group (``layouts_ambiguous``: the layouts the authors
    labelled ambiguous; ``layouts_clear``: the others) or the set itself."""
    if scene_set not in (AMBIGUOUS_LAYOUTS, CLEAR_LAYOUTS):
        return {scene_set}
    ambiguous = set(get_task(task).ambiguous_layouts)
    return {layout_name(k) for k in LAYOUT_IDS if (k in ambiguous) == (scene_set == AMBIGUOUS_LAYOUTS)}


def paired_comparisons(records: list[TrajectoryRecord], scene_sets, *, pairs=PAIRS, metrics=PAIRED_METRICS) -> list[dict]:
    """Every pair × metric × task × scene set (or layout group) that both methods ran: mean
    difference and 95 % interval (scene-clustered where scenes repeat)."""
    out = []
    for task in sorted({r.task for r in records}):
        for scene_set in scene_sets:
            members = scene_set_members(task, scene_set)
            group = [r for r in records if r.task == task and r.scene_set in members]
            methods = {r.method for r in group}
            for a, b in pairs:
                if a in methods and b in methods:
                    out += [compare(group, a, b, m).row(task=task, scene_set=scene_set) for m in metrics]
    return out


def comparisons_markdown(rows: list[dict]) -> str:
    """The paired differences (rows of :meth:`PairedDifference.row` with their task and scene set) as a
    Markdown table (mean and [95 % interval]; * excludes zero, from at least :data:`MIN_STARRED` pairs)."""
    lines = ["| task | scene set | difference | metric | pairs | scenes | mean [95 % CI] |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        d = PairedDifference.from_row({"scenes": r["n"], **r})
        lines.append(f"| {r['task']} | {r['scene_set']} | {d.a} − {d.b} | {d.metric} | {d.n} | {d.scenes} | "
                     f"{d.cell()}{' *' if d.starred else ''} |")
    return "\n".join(lines) + "\n"
