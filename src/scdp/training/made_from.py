"""What a trained part was made from: the one record that ``scdp train``, ``train --resume`` and
``scdp reproduce`` all write and read.

A part's record is a dict of names to content hashes (:func:`made_from`):

=========  ================================================  ===========================
name       what                                               parts
=========  ================================================  ===========================
format     :data:`FORMAT`, the version of what stages write   every part
recipe     SHA-256 of :func:`~scdp.training.recipe.part_recipe` every part
task       :func:`scdp.tasks.fingerprint.task_fingerprint`    every part
demos      the demonstrations' fingerprint (all of them)      every part but the encoder
base       SHA-256 of the base's ``model.safetensors``        predictors; LD when fine-tuned
encoder    SHA-256 of the encoder's ``model.safetensors``     predictors
=========  ================================================  ===========================

The trainer keeps it as the job a resumed run must match, and writes it to :data:`RECORD` beside
the weights when the part is finished; ``reproduce`` skips a part exactly when that file equals
the record it computes today (:mod:`scdp.pipeline.fingerprints`). File times play no part.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from scdp.config import Preset
from scdp.io import read_json_object, write_json
from scdp.policies.checkpoint import RECORD, file_sha256
from scdp.tasks import Task
from scdp.tasks.fingerprint import task_fingerprint
from scdp.training.recipe import base_dependent, part_recipe

FORMAT = 1  # raise when what a stage writes changes meaning: every output is then redone


def digest(obj) -> str:
    """SHA-256 of ``obj`` as canonical JSON (sorted keys, no spaces)."""
    return hashlib.sha256(json.dumps(obj, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def weights_hash(folder) -> str | None:
    """SHA-256 of a part's ``model.safetensors`` (None when there is none)."""
    path = Path(folder) / "model.safetensors"
    return file_sha256(path) if path.is_file() else None


def needs(preset: Preset, part: str) -> tuple[str, ...]:
    """The upstream inputs ``part`` is made from, beyond its recipe and task: a subset of
    ("demos", "base", "encoder")."""
    if part == "encoder":
        return ()
    return ("demos",) + (("base",) if base_dependent(preset, part) else ()) + (("encoder",) if part.startswith("style_") else ())


def made_from(task: Task, preset: Preset, part: str, *, demos: str | None = None, base: str | None = None,
              encoder: str | None = None) -> dict:
    """The record of ``part`` made with ``preset`` for ``task`` from the demos of fingerprint
    ``demos`` and the base and encoder weights of SHA-256 ``base``, ``encoder`` (each read only
    where the part needs it: :func:`needs`)."""
    given = {"demos": demos, "base": base, "encoder": encoder}
    record = {"format": FORMAT, "recipe": digest(part_recipe(preset, part)), "task": task_fingerprint(task)}
    return {**record, **{name: given[name] for name in needs(preset, part)}}


def read_record(folder) -> dict | None:
    """The record a finished part wrote (None: no record, or an unreadable one)."""
    return read_json_object(Path(folder) / RECORD)


def write_record(folder, record: dict) -> None:
    write_json(Path(folder) / RECORD, record)


def changes(recorded: dict | None, current: dict) -> list[str]:
    """The names of the inputs that differ between ``recorded`` and ``current`` ([] when equal)."""
    if recorded is None:
        return ["no record of its inputs"]
    return [k for k in sorted(set(recorded) | set(current)) if recorded.get(k) != current.get(k)]


def adoptable(recorded: dict | None, current: dict) -> bool:
    """Whether ``recorded`` was written before scdp recorded some of today's inputs and agrees on
    every one it names (``reproduce --adopt`` then takes it as made from today's values of the
    others). A record that names a different value is never adoptable."""
    return (recorded is not None and set(recorded) < set(current)
            and all(current[k] == v for k, v in recorded.items()))
