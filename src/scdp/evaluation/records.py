"""Trajectory records: one scored rollout, the unit of ``results.json``.

:func:`score_rollout` turns an executed :class:`~scdp.evaluation.rollout.Rollout` into a
:class:`TrajectoryRecord` with every metric of :func:`scdp.scoring.score.score_path`;
:func:`summarize` gives mean and std over records; :func:`record_value` reads a metric of a
record, derived ones included (``success``, the failure-aware ``transparency_fa``);
:func:`scene_key` names the scene a record was rolled out in; :func:`load_records` reads a
``results.json`` or ``trajectories.json``, including those written before the fixed goal
pairs were called *layouts* (``config_k`` scene sets, the ``per_config`` protocol).
"""

from __future__ import annotations

import re
from collections import OrderedDict
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from scdp import metrics, scoring
from scdp.errors import ScdpError
from scdp.io import read_json
from scdp.keys import layout_name, layout_number
from scdp.tasks import Task

PATH_DECIMALS = 4  # stored paths are rounded to 0.1 mm (or 0.1 mrad) before they are scored
METRIC_KEYS = ("detachment", "efficiency", "d_hat", "e_hat", "transparency", "legibility")
FAILURE_AWARE = "transparency_fa"  # T on a success, min(T, 0) on a failure (metrics.failure_aware_transparency)
BOUNDED = "transparency_bounded"  # D̂, Ê clipped to [0, 1], 0 on a failure (metrics.bounded_transparency): sensitivity only
SUMMARY_KEYS = ("transparency", FAILURE_AWARE, "d_hat", "e_hat", "legibility")


@dataclass
class TrajectoryRecord:
    """One method's executed trajectory in one scene, scored.

    goals (K, G) and path (T + 1, G) are task-space lists (the path rounded to
    :data:`PATH_DECIMALS`, and scored *as stored*, so every metric recomputes from the record:
    :func:`rescore` does it);
    ``bounds`` are the scene's reference bounds (d_min, d_max, e_min, e_max); ``metrics``
    holds :data:`METRIC_KEYS`; ``styles`` has one entry per planned chunk; ``seconds`` is the
    amortised planning time. ``protocol`` is set when records of several protocols are merged;
    ``training_seed`` when records of models trained with several seeds are pooled (the same
    scene under several seeds: pairs stay within a seed, :func:`scene_key` ignores the seed).
    """

    task: str
    scene_set: str
    method: str
    goals: list
    target: int
    path: list
    success: bool
    bounds: dict
    j_hat: float
    metrics: dict
    beta: float
    styles: list = field(default_factory=list)
    seconds: float = 0.0
    scene_index: int | None = None  # place of the scene in its set: records of one scene pair up across methods
    protocol: str | None = None
    training_seed: int | None = None
    failure: str | None = None  # why the rollout was ended early (left the state bounds, ...): None when it ran its course

    def to_dict(self) -> dict:
        optional = ("protocol", "scene_index", "training_seed", "failure")
        return {k: v for k, v in asdict(self).items() if v is not None or k not in optional}

    @classmethod
    def from_dict(cls, d: dict) -> TrajectoryRecord:
        """Read a record, renaming the names of files written before layouts had their name."""
        names = {f.name for f in fields(cls)}
        try:
            record = cls(**{k: v for k, v in d.items() if k in names})
        except TypeError as exc:
            raise ScdpError("results", f"not a trajectory record ({exc})") from None
        if (old := re.fullmatch(r"config_(\d)", record.scene_set)) is not None:  # the name before layouts
            record.scene_set = layout_name(int(old[1]))
        if record.protocol == "per_config":
            record.protocol = "per_layout"
        return record


class BoundedCache(OrderedDict):
    """A dict that keeps only its ``maxsize`` most recently used entries: a long-running service's
    :func:`scene_bounds` memo, whose memory stays bounded however many scenes it scores."""

    def __init__(self, maxsize: int):
        super().__init__()
        self.maxsize = maxsize

    def __getitem__(self, key):
        value = super().__getitem__(key)
        self.move_to_end(key)
        return value

    def __setitem__(self, key, value):
        super().__setitem__(key, value)
        self.move_to_end(key)
        while len(self) > self.maxsize:
            self.popitem(last=False)


def scene_bounds(task: Task, goals, target, cache: dict | None = None, references: int = scoring.DEFAULT_REFERENCES):
    """Reference bounds of a scene, memoised in ``cache`` (a dict, or a :class:`BoundedCache`) by the
    scene's coordinates."""
    key = (np.round(np.asarray(goals), 6).tobytes(), int(target))
    if cache is not None and key in cache:
        return cache[key]
    bounds = scoring.reference_bounds(task, goals, target, n=references)
    if cache is not None:
        cache[key] = bounds
    return bounds


def score_rollout(task: Task, run, *, method: str, scene_set: str, bounds, scene_index: int | None = None,
                  beta: float = metrics.DEFAULT_BETA) -> TrajectoryRecord:
    """Score an executed rollout in its scene: the path is rounded first, so the stored path is
    exactly the one scored."""
    path = np.asarray(run.path, dtype=np.float64).round(PATH_DECIMALS)
    m = scoring.score_path(task, path, run.goals, run.target, bounds, beta=beta)
    return TrajectoryRecord(
        task=task.name, scene_set=scene_set, method=method, goals=np.asarray(run.goals).tolist(), target=int(run.target),
        path=path.tolist(), success=bool(run.success), bounds=bounds.to_dict(), j_hat=m["j_hat"],
        metrics={k: m[k] for k in METRIC_KEYS}, beta=beta, styles=list(run.styles), seconds=float(run.seconds),
        scene_index=scene_index, failure=run.failure or None,
    )


def rescore(task: Task, record: TrajectoryRecord) -> dict:
    """Every metric of :data:`METRIC_KEYS` recomputed from what the record stores (its path, goals,
    target, bounds and beta): an independent check of a ``results.json``."""
    m = scoring.score_path(task, np.asarray(record.path), record.goals, record.target,
                           scoring.Bounds(**record.bounds), beta=record.beta)
    return {k: m[k] for k in METRIC_KEYS}


def record_value(record: TrajectoryRecord, name: str) -> float:
    """A record's value of a metric: a key of its ``metrics``, ``success`` (0/1),
    ``transparency_fa``, derived from T and success by :func:`scdp.metrics.failure_aware_transparency`,
    or ``transparency_bounded`` (:func:`scdp.metrics.bounded_transparency`)."""
    if name == "success":
        return float(record.success)
    if name == FAILURE_AWARE and FAILURE_AWARE not in record.metrics:
        return metrics.failure_aware_transparency(record.metrics["transparency"], record.success)
    if name == BOUNDED and BOUNDED not in record.metrics:
        return metrics.bounded_transparency(record.metrics["d_hat"], record.metrics["e_hat"], record.j_hat, record.success)
    return float(record.metrics[name])


def scene_key(record: TrajectoryRecord, position: int | None = None) -> tuple:
    """The scene a record was rolled out in, the unit a cluster bootstrap resamples.

    A random scene is (task, scene set, scene index); a layout's records are its rollouts of
    ``layout_repeats`` × both targets (scene index ``2 * repeat + target``), so a layout scene
    is (task, layout, target) and its repeats, which differ only in noise, are one scene. The
    protocol and the training seed are not part of it: the same scene under another seed's
    models is the same scene. ``position`` stands in for a missing scene index (old files).
    """
    if layout_number(record.scene_set) is not None:
        return record.task, record.scene_set, "target", int(record.target)
    index = record.scene_index if record.scene_index is not None else position
    return record.task, record.scene_set, index


def early_failures(records: list[TrajectoryRecord]) -> dict[str, list[str]]:
    """The rollouts ended early (a state or planned action outside the bounds), by method: each
    one's reason, in record order; methods without any are left out."""
    out: dict[str, list[str]] = {}
    for r in records:
        if r.failure:
            out.setdefault(r.method, []).append(r.failure)
    return out


def failures_line(records: list[TrajectoryRecord]) -> str:
    """One line counting :func:`early_failures` per method with the first reason ("" when none)."""
    found = early_failures(records)
    parts = [f"{m} {len(v)} of {sum(r.method == m for r in records)} (first: {v[0]})" for m, v in found.items()]
    return ("Rollouts ended early, each counted as a failure of that rollout alone: " + "; ".join(parts) + ".") if parts else ""


def summarize(records: list[TrajectoryRecord]) -> dict:
    """Mean and std of T, T_fa, d_hat, e_hat, legibility, success and seconds over records; style shares."""
    def stat(values):
        v = np.asarray(values, dtype=np.float64)
        return {"mean": float(v.mean()), "std": float(v.std())} if len(v) else {"mean": float("nan"), "std": float("nan")}

    out = {k: stat([record_value(r, k) for r in records]) for k in SUMMARY_KEYS}
    out["success"] = stat([float(r.success) for r in records])
    out["seconds"] = stat([r.seconds for r in records])
    out["n"] = len(records)
    styles = [s for r in records for s in r.styles]
    if styles:
        out["style_share"] = {s: styles.count(s) / len(styles) for s in sorted(set(styles))}
    return out


def load_records(path) -> list[TrajectoryRecord]:
    """The records of a ``results.json`` (key ``trajectories``) or ``trajectories.json`` (key ``records``),
    either of them possibly gzip-compressed (``.json.gz``)."""
    path = Path(path)
    try:
        data = read_json(path)
    except (OSError, ValueError) as exc:
        raise ScdpError("results", f"{path} is not readable JSON ({exc})") from None
    rows = data.get("trajectories", data.get("records")) if isinstance(data, dict) else None
    if not isinstance(rows, list):
        raise ScdpError("results", f"{path} holds no trajectory records")
    return [TrajectoryRecord.from_dict(r) for r in rows]
