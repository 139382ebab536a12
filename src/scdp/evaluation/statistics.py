"""Paired comparisons of methods: differences on the same scenes, with bootstrap intervals.

Every method is rolled out on the same scenes with the same per-scene noise, so the record of
method A and the record of method B for one scene form a pair. A claim "A beats B" holds only
when the 95 % bootstrap interval of the mean paired difference excludes zero in its direction.
"""

from __future__ import annotations

import numpy as np

from scdp.evaluation.records import TrajectoryRecord

BOOTSTRAP_SAMPLES = 10_000


def bootstrap_interval(values, *, level: float = 0.95, samples: int = BOOTSTRAP_SAMPLES, seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``values`` (seeded, so reports are reproducible)."""
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        return float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    means = values[rng.integers(0, len(values), size=(samples, len(values)))].mean(axis=1)
    tail = 100 * (1 - level) / 2
    return float(np.percentile(means, tail)), float(np.percentile(means, 100 - tail))


def _key(r: TrajectoryRecord, position: int):
    return (r.task, r.protocol, r.scene_set, r.scene_index if r.scene_index is not None else position)


def paired(records: list[TrajectoryRecord], a: str, b: str, value) -> np.ndarray:
    """``value(record_a) - value(record_b)`` over every scene both methods ran, in scene order.

    Scenes pair up by (task, protocol, scene set, scene index); records without a scene index
    (files written before it existed) pair by their order within the set.
    """
    def index(method):
        out, seen = {}, {}
        for r in records:
            if r.method == method:
                group = (r.task, r.protocol, r.scene_set)
                seen[group] = seen.get(group, -1) + 1
                out[_key(r, seen[group])] = r
        return out

    ra, rb = index(a), index(b)
    keys = [k for k in ra if k in rb]
    return np.array([value(ra[k]) - value(rb[k]) for k in keys], dtype=np.float64)


def metric_of(name: str):
    """A record's value for a metric name: a key of ``metrics``, or ``success`` (0/1)."""
    if name == "success":
        return lambda r: float(r.success)
    return lambda r: float(r.metrics[name])


def compare(records: list[TrajectoryRecord], a: str, b: str, metric: str, *, seed: int = 0) -> dict:
    """Mean paired difference ``a - b`` of ``metric`` with its 95 % bootstrap interval, and n."""
    diffs = paired(records, a, b, metric_of(metric))
    lo, hi = bootstrap_interval(diffs, seed=seed)
    return {"a": a, "b": b, "metric": metric, "n": int(len(diffs)),
            "mean": float(diffs.mean()) if len(diffs) else float("nan"), "lo": lo, "hi": hi}


def holds(comparison: dict, direction: str = ">") -> bool:
    """The interval excludes zero in the claimed direction (``>``: a above b; ``<``: a below b)."""
    return comparison["lo"] > 0 if direction == ">" else comparison["hi"] < 0


PAIRS = (("scdp", "dp"), ("scdp", "ld"), ("scdp", "ld_paper"), ("scdp", "dataset"), ("scdp_blend", "dp"),
         ("scdp_legible", "scdp_efficient"))
PAIRED_METRICS = ("transparency", "d_hat", "e_hat")


def paired_comparisons(records: list[TrajectoryRecord], scene_sets, *, pairs=PAIRS, metrics=PAIRED_METRICS) -> list[dict]:
    """Every pair × metric × task × scene set that both methods ran: mean difference and 95 % interval."""
    out = []
    for task in sorted({r.task for r in records}):
        for scene_set in scene_sets:
            group = [r for r in records if r.task == task and r.scene_set == scene_set]
            methods = {r.method for r in group}
            for a, b in pairs:
                if a in methods and b in methods:
                    out += [{"task": task, "scene_set": scene_set, **compare(group, a, b, m)} for m in metrics]
    return out


def comparisons_markdown(rows: list[dict]) -> str:
    """The paired differences as a Markdown table (mean and [95 % interval]; * excludes zero)."""
    lines = ["| task | scene set | difference | metric | n | mean [95 % CI] |", "|---|---|---|---|---|---|"]
    for r in rows:
        star = " *" if r["lo"] > 0 or r["hi"] < 0 else ""
        lines.append(f"| {r['task']} | {r['scene_set']} | {r['a']} − {r['b']} | {r['metric']} | {r['n']} | "
                     f"{r['mean']:+.3f} [{r['lo']:+.3f}, {r['hi']:+.3f}]{star} |")
    return "\n".join(lines) + "\n"
