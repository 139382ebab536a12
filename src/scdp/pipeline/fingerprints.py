"""What each stage output was made from, by content: the key on which ``reproduce`` skips a stage.

A stage's *inputs* are a dict of names to content hashes: the hash of its recipe
(:func:`scdp.training.recipe.part_recipe`), the demonstrations' fingerprint
(:meth:`scdp.data.dataset.DemoDataset.fingerprint`), the SHA-256 of the weights of every part it
starts from, and :data:`FORMAT`, the version of what stages write. A trained part records them in
``inputs.json`` beside its weights when it finishes; the evaluation keeps them in its
``trajectories.json``. A stage is skipped exactly when the recorded inputs equal the current
ones, and redone otherwise, its log naming the inputs that changed. File times play no part:
touching, copying or checking out a run changes nothing, and one changed byte of the demos or
of a part's weights redoes what was made from them (as a build system with content keys does).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from scdp.data.dataset import DemoDataset
from scdp.errors import ScdpError
from scdp.io import read_json, write_json
from scdp.policies.checkpoint import file_sha256

FORMAT = 1  # raise when what a stage writes changes meaning: every output is then redone
RECORD = "inputs.json"  # a trained part's inputs, beside its weights


def digest(obj) -> str:
    """SHA-256 of ``obj`` as canonical JSON (sorted keys, no spaces)."""
    return hashlib.sha256(json.dumps(obj, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def weights_hash(folder: Path) -> str | None:
    """SHA-256 of a part's ``model.safetensors`` (None when there is none)."""
    path = Path(folder) / "model.safetensors"
    return file_sha256(path) if path.is_file() else None


def demos_hash(path: Path) -> str | None:
    """The demonstrations' content fingerprint (None when ``path`` holds no readable dataset)."""
    try:
        return DemoDataset.load(path).fingerprint()
    except ScdpError:
        return None


def read_record(folder: Path) -> dict | None:
    """The inputs a part recorded when it finished (None: no record, or an unreadable one)."""
    try:
        record = read_json(Path(folder) / RECORD)
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) else None


def write_record(folder: Path, inputs: dict) -> None:
    write_json(Path(folder) / RECORD, inputs)


def changes(recorded: dict | None, current: dict) -> list[str]:
    """The names of the inputs that differ between ``recorded`` and ``current`` ([] when equal)."""
    if recorded is None:
        return ["no record of its inputs"]
    return [k for k in sorted(set(recorded) | set(current)) if recorded.get(k) != current.get(k)]
