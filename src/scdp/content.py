"""Content keys, in one place: how every stored output says what it was made from.

An output's *inputs* are a dict of names to content hashes (or, for a task, to its key,
:func:`scdp.data.task_key.task_key`). A stage is skipped exactly when the inputs it recorded equal
today's (:mod:`scdp.pipeline.fingerprints`); file times play no part. This module holds the pieces
every writer and reader of those records shares: the canonical digest, a file's SHA-256, the
format version, the record file's name, and how two records differ.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

FORMAT = 1  # raise when what a stage writes changes meaning: every output is then redone
RECORD = "inputs.json"  # what a finished part was made from (scdp.training.made_from), beside its weights


def digest(obj) -> str:
    """SHA-256 of ``obj`` as canonical JSON (sorted keys, no spaces)."""
    return hashlib.sha256(json.dumps(obj, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def file_sha256(path: Path) -> str:
    """SHA-256 of a file's bytes, read in 1 MiB blocks."""
    sha = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            sha.update(block)
    return sha.hexdigest()


def changes(recorded: dict | None, current: dict) -> list[str]:
    """The names of the inputs that differ between ``recorded`` and ``current`` ([] when equal)."""
    if recorded is None:
        return ["no record of its inputs"]
    return [k for k in sorted(set(recorded) | set(current)) if recorded.get(k) != current.get(k)]


def _short(value) -> str:
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _task_words(recorded, current) -> str:
    """What changed in a task's key: the fields with both values, then the probe outputs by name."""
    if not (isinstance(recorded, dict) and isinstance(current, dict)):
        return "task (recorded under an older task key)"
    old, new = recorded.get("fields", {}), current.get("fields", {})
    words = [f"field {k} {_short(old.get(k))} -> {_short(new.get(k))}"
             for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]
    old, new = recorded.get("probe", {}), current.get("probe", {})
    words += [f"probe {k}" for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]
    return f"task ({'; '.join(words)})"


def explain(recorded: dict | None, current: dict) -> list[str]:
    """:func:`changes` in words for a log: a changed task names its changed fields, with both values,
    and its changed probe outputs."""
    return [_task_words(recorded.get(k), current.get(k)) if k == "task" and recorded is not None else k
            for k in changes(recorded, current)]


def under_an_older_task_key(recorded: dict | None, current: dict) -> bool:
    """Whether ``recorded`` differs from ``current`` only in its task, recorded under the task key
    scdp used before keys were taken by behaviour (a hash of the task classes' source text). Such a
    record is adopted only where today's code makes the recorded demos again bit for bit."""
    return (recorded is not None and isinstance(recorded.get("task"), str) and isinstance(current.get("task"), dict)
            and set(recorded) == set(current) and all(recorded[k] == v for k, v in current.items() if k != "task"))


def adoptable(recorded: dict | None, current: dict) -> bool:
    """Whether ``recorded`` was written before scdp recorded some of today's inputs and agrees on
    every one it names (``reproduce --adopt`` then takes it as made from today's values of the
    others). A record that names a different value is never adoptable."""
    return (recorded is not None and set(recorded) < set(current)
            and all(current[k] == v for k, v in recorded.items()))
