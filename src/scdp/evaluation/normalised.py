"""Records read under either normalisation of D̂, Ê and ĵ (:mod:`scdp.scoring.normalisation`).

A stored record is scored per scene (``scene``). :func:`under` gives copies of records read over
the training data (``dataset``): D̂, Ê, ĵ and T recomputed from the raw D and E the record stores,
against the :class:`~scdp.scoring.DatasetRange` of the demonstrations its models learned from.
Nothing is rolled out or trained again; the path, success, legibility and style of every record are
unchanged, and so is anything an observer reads from the path.

The range a record is read against is named by :func:`range_key`: the task's random-scene training
set, or (the authors' per-layout protocol) the layout's own demonstrations.
"""

from __future__ import annotations

from dataclasses import replace

from scdp import metrics
from scdp.errors import ScdpError
from scdp.evaluation.records import BOUNDED, FAILURE_AWARE, TrajectoryRecord
from scdp.keys import DATASET_NORMALISATION, PER_LAYOUT, SCENE_NORMALISATION
from scdp.scoring import DatasetRange, check_normalisation, normalise

DERIVED = (FAILURE_AWARE, BOUNDED)  # metrics read from T and success (records.record_value), dropped to be derived again


def range_key(record: TrajectoryRecord) -> str:
    """The training set whose range a record is read against: ``task``, or ``task/layout_k`` for a
    record of the per-layout protocol (each layout's models learned from that layout alone)."""
    return f"{record.task}/{record.scene_set}" if record.protocol == PER_LAYOUT else record.task


def range_parts(key: str) -> tuple[str, str | None]:
    """A :func:`range_key` as (task, the per-layout set's layout or None)."""
    task, _, layout = key.partition("/")
    return task, layout or None


def dataset_reading(record: TrajectoryRecord, rng: DatasetRange) -> TrajectoryRecord:
    """A copy of ``record`` with D̂, Ê, ĵ and T over the training data's range ``rng`` (its bounds
    become the range's D and E, so :func:`scdp.evaluation.records.rescore` agrees with it)."""
    d_hat, e_hat, j_hat = normalise(record.metrics["detachment"], record.metrics["efficiency"], record.goals,
                                    record.target, rng)
    kept = {k: v for k, v in record.metrics.items() if k not in DERIVED}
    return replace(record, j_hat=j_hat, bounds={"d_min": rng.d_min, "d_max": rng.d_max, "e_min": rng.e_min, "e_max": rng.e_max},
                   metrics={**kept, "d_hat": d_hat, "e_hat": e_hat,
                            "transparency": float(metrics.transparency(d_hat, e_hat, j_hat))})


def under(records: list[TrajectoryRecord], normalisation: str, ranges: dict | None = None) -> list[TrajectoryRecord]:
    """The records under ``normalisation``: themselves for ``scene``, copies read over the training
    data for ``dataset`` (``ranges`` maps :func:`range_key` to a :class:`DatasetRange`)."""
    check_normalisation(normalisation)
    if normalisation == SCENE_NORMALISATION:
        return list(records)
    ranges = ranges or {}
    missing = sorted({range_key(r) for r in records} - set(ranges))
    if missing:
        raise ScdpError("normalisation", f"no training-data range for {', '.join(missing)}: the {DATASET_NORMALISATION} "
                                         "reading needs the demonstrations the models learned from (their demos.zarr)")
    return [dataset_reading(r, ranges[range_key(r)]) for r in records]


def read_ranges(stored) -> dict[str, DatasetRange]:
    """The ranges a ``results.json`` stores (``normalisation_ranges``), checked."""
    if not isinstance(stored, dict):
        return {}
    return {key: DatasetRange.from_dict(value, f"normalisation_ranges/{key}") for key, value in stored.items()}
