"""What a trained part was made from: the one record that ``scdp train``, ``train --resume`` and
``scdp reproduce`` all write and read.

A part's record is a dict of names to content hashes (:func:`made_from`):

=========  ================================================  ===========================
name       what                                               parts
=========  ================================================  ===========================
format     :data:`FORMAT`, the version of what stages write   every part
recipe     SHA-256 of :func:`~scdp.training.recipe.part_recipe` every part
task       :func:`scdp.data.task_key.task_key`               every part
demos      the demonstrations' fingerprint (all of them)      every part but the encoder
base       SHA-256 of the base's ``model.safetensors``        predictors; LD when fine-tuned
encoder    SHA-256 of the encoder's ``model.safetensors``     predictors, the student
styles     SHA-256 of both predictors' weight hashes          the student
=========  ================================================  ===========================

The trainer keeps it as the job a resumed run must match, and writes it to :data:`RECORD` beside
the weights when the part is finished; ``reproduce`` skips a part exactly when that file equals
the record it computes today (:mod:`scdp.pipeline.fingerprints`). File times play no part.
"""

from __future__ import annotations

from pathlib import Path

from scdp.config import Preset
from scdp.content import FORMAT, RECORD, digest, file_sha256
from scdp.data.task_key import task_key
from scdp.io import read_json_object, write_json
from scdp.keys import STUDENT_PART, STYLES, is_style_part, style_part
from scdp.tasks import Task
from scdp.training.recipe import base_dependent, part_recipe


def weights_hash(folder) -> str | None:
    """SHA-256 of a part's ``model.safetensors`` (None when there is none)."""
    path = Path(folder) / "model.safetensors"
    return file_sha256(path) if path.is_file() else None


def styles_hash(checkpoints) -> str | None:
    """One hash of the two style predictors' weights in ``checkpoints`` (what the student distils with)."""
    hashes = [weights_hash(Path(checkpoints) / style_part(s)) for s in STYLES]
    return None if None in hashes else digest(hashes)


def needs(preset: Preset, part: str) -> tuple[str, ...]:
    """The upstream inputs ``part`` is made from, beyond its recipe and task: a subset of
    ("demos", "base", "encoder", "styles")."""
    if part == "encoder":
        return ()
    if part == STUDENT_PART:
        return ("demos", "base", "encoder", "styles")
    return ("demos",) + (("base",) if base_dependent(preset, part) else ()) + (("encoder",) if is_style_part(part) else ())


def made_from(task: Task, preset: Preset, part: str, *, demos: str | None = None, base: str | None = None,
              encoder: str | None = None, styles: str | None = None) -> dict:
    """The record of ``part`` made with ``preset`` for ``task`` from the demos of fingerprint
    ``demos``, the base and encoder weights of SHA-256 ``base``, ``encoder`` and the predictors'
    ``styles`` (:func:`styles_hash`), each read only where the part needs it (:func:`needs`)."""
    given = {"demos": demos, "base": base, "encoder": encoder, "styles": styles}
    record = {"format": FORMAT, "recipe": digest(part_recipe(preset, part)), "task": task_key(task)}
    return {**record, **{name: given[name] for name in needs(preset, part)}}


def read_record(folder) -> dict | None:
    """The record a finished part wrote (None: no record, or an unreadable one)."""
    return read_json_object(Path(folder) / RECORD)


def write_record(folder, record: dict) -> None:
    write_json(Path(folder) / RECORD, record)
