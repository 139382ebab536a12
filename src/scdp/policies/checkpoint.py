"""Checkpoints: one folder per trained part, ``model.safetensors`` + ``config.json``. No pickle.

Parts and what they hold::

    base/             DiffusionPolicy (EMA weights), for DP and SCDP
    ld/               DiffusionPolicy trained with goal dropout, for Legibility Diffuser
    encoder/          SceneAutoencoder
    style_legible/    StylePredictor
    style_efficient/  StylePredictor

``config.json`` records ``format_version``, ``part``, ``task``, ``preset`` (and its
``overrides``), the model config, the normaliser statistics, the training schedule, the
parameter count, the SHA-256 of ``model.safetensors`` (checked on load, so flipped bytes are
refused) and whether training finished; Legibility Diffuser's part also records its
guidance. This module reads and writes those files; :mod:`scdp.policies.loaders` builds
models and planners from them.
"""

from __future__ import annotations

import json
from pathlib import Path

import torch
from safetensors import SafetensorError, safe_open
from safetensors.torch import save_file

from scdp.content import RECORD, file_sha256
from scdp.errors import ScdpError
from scdp.io import atomic_path, write_json
from scdp.models.unet1d import count_parameters
from scdp.tasks import Task

ONNX_FILE, ONNX_META = "model.onnx", "onnx.json"  # a part's exported denoiser (scdp.policies.exported)
EXPORTED_FILES = (ONNX_META, ONNX_FILE)

FORMAT_VERSION = 1
# every top-level key a part's config.json may hold: what save_part writes, and what training adds per part
META_KEYS = frozenset({"format_version", "part", "task", "preset", "config", "normalizer", "parameters", "complete",
                       "weights_sha256", "train", "overrides", "recipe", "train_seconds", "demos", "guidance", "init",
                       "scenes", "subset_demos", "windows", "style", "arbitration", "autoencoder_parameters",
                       "distilled"})  # the student's: its teacher's sampler and steps, its styled share
CHECKPOINT_FILES = ("config.json", "model.safetensors", RECORD, "train_state.json", "train_state.safetensors")


def check_checkpoint_folder(folder) -> Path:
    """Refuse to train into ``folder`` when it is a file or holds anything but a checkpoint's own
    files (hidden temporaries of an interrupted write excepted): a mistyped ``--out`` must not
    mix weights into someone's data."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ScdpError("--out", f"{folder} is a file, not a checkpoint folder")
    strangers = sorted(p.name for p in folder.iterdir() if p.name not in CHECKPOINT_FILES
                       and not p.name.startswith(".")) if folder.is_dir() else []
    if strangers:
        shown = ", ".join(strangers[:3]) + (f" and {len(strangers) - 3} more" if len(strangers) > 3 else "")
        raise ScdpError("--out", f"{folder} holds files that are not a checkpoint's ({shown}); choose a new or empty folder")
    return folder


def save_tensors(path: Path, tensors: dict[str, torch.Tensor], metadata: dict[str, str] | None = None) -> None:
    """Write tensors (and string ``metadata``) to a safetensors file, atomically."""
    with atomic_path(path) as tmp:
        save_file({k: v.detach().contiguous().cpu() for k, v in tensors.items()}, str(tmp), metadata=metadata)


def load_tensors(path: Path, field: str) -> dict[str, torch.Tensor]:
    """Read a safetensors file; a missing or damaged file is an :class:`ScdpError` on ``field``."""
    return load_tensors_and_metadata(path, field)[0]


def load_tensors_and_metadata(path: Path, field: str) -> tuple[dict[str, torch.Tensor], dict[str, str]]:
    """Tensors and string metadata of a safetensors file (see :func:`load_tensors`)."""
    if not path.exists():
        raise ScdpError(field, f"{path} is missing")
    try:
        with safe_open(str(path), framework="pt") as f:
            return {k: f.get_tensor(k) for k in f.keys()}, dict(f.metadata() or {})
    except (SafetensorError, OSError, ValueError, RuntimeError) as exc:
        raise ScdpError(field, f"{path} is corrupt ({exc})") from None


def save_part(folder, module: torch.nn.Module, *, part: str, task: str, preset: str, config, normalizer=None,
              complete: bool = True, extra: dict | None = None) -> Path:
    """Write ``model.safetensors`` then ``config.json`` (each atomically). A graph exported from the
    folder's earlier weights (:data:`EXPORTED_FILES`) is removed first: it no longer matches."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name in EXPORTED_FILES:
        (folder / name).unlink(missing_ok=True)
    save_tensors(folder / "model.safetensors", module.state_dict())
    meta = {
        "format_version": FORMAT_VERSION, "part": part, "task": task, "preset": preset,
        "config": config.to_dict(), "normalizer": normalizer.to_dict() if normalizer else None,
        "parameters": count_parameters(module), "complete": complete,
        "weights_sha256": file_sha256(folder / "model.safetensors"), **(extra or {}),
    }
    write_json(folder / "config.json", meta)
    return folder


def read_meta(folder, part: str, task: Task | None=None) -> dict:
    """Validated ``config.json`` of a part folder: a JSON object of this format version, part and task,
    finished, with a model config and no key outside :data:`META_KEYS`."""
    folder = Path(folder)
    path = folder / "config.json"
    if not path.exists():
        raise ScdpError(f"checkpoints/{part}", f"{folder} holds no {part} checkpoint (no config.json)")
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ScdpError(f"checkpoints/{part}", f"{path} is corrupt ({exc})") from None
    if not isinstance(meta, dict):
        raise ScdpError(f"checkpoints/{part}", f"{path} must hold a JSON object, got {type(meta).__name__}")
    if meta.get("format_version") != FORMAT_VERSION:
        raise ScdpError(f"checkpoints/{part}", f"format version {meta.get('format_version')!r}, expected {FORMAT_VERSION}")
    if meta.get("part") != part:
        raise ScdpError(f"checkpoints/{part}", f"{folder} holds a {meta.get('part')!r} checkpoint")
    if task is not None and meta.get("task") != task.name:
        raise ScdpError("task", f"checkpoint {folder} was trained for {meta.get('task')!r}, not {task.name!r}")
    if not meta.get("complete", False):
        raise ScdpError(f"checkpoints/{part}", f"{folder} holds an unfinished training run (resume it with --resume)")
    if not isinstance(meta.get("config"), dict):
        raise ScdpError(f"checkpoints/{part}", f"{path} has no model config object")
    unknown = sorted(str(k) for k in meta if k not in META_KEYS)
    if unknown:  # as unknown keys inside "config" are: a typo or another program's file is not ignored
        shown = ", ".join(repr(k[:40]) for k in unknown[:3]) + (f" and {len(unknown) - 3} more" if len(unknown) > 3 else "")
        raise ScdpError(f"checkpoints/{part}", f"{path} holds unknown key(s) {shown}")
    return meta


def load_weights(module: torch.nn.Module, folder: Path, part: str, meta: dict) -> torch.nn.Module:
    """Load ``folder/model.safetensors`` into ``module`` (strict) and put it in eval mode, after
    checking it against the SHA-256 that ``meta`` (its :func:`read_meta`) recorded; older
    checkpoints recorded none."""
    path = folder / "model.safetensors"
    recorded = meta.get("weights_sha256")
    if recorded is not None and path.exists() and file_sha256(path) != recorded:
        raise ScdpError(f"checkpoints/{part}", f"{path} does not match the SHA-256 in config.json (damaged or replaced)")
    state = load_tensors(path, f"checkpoints/{part}")
    try:
        module.load_state_dict(state, strict=True)
    except RuntimeError as exc:
        first = str(exc).strip().splitlines()
        raise ScdpError(f"checkpoints/{part}",
                        f"weights do not fit the config ({first[1].strip() if len(first) > 1 else first[0]})") from None
    return module.eval()
