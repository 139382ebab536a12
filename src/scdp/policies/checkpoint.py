"""Checkpoints: one folder per trained part, ``model.safetensors`` + ``config.json``. No pickle.

Parts and what they hold::

    base/             DiffusionPolicy (EMA weights), for DP and SCDP
    ld/               DiffusionPolicy trained with goal dropout, for Legibility Diffuser
    encoder/          SceneAutoencoder
    style_legible/    StylePredictor
    style_efficient/  StylePredictor

``config.json`` records ``format_version``, ``part``, ``task``, ``preset``, the model config,
the normaliser statistics, the parameter count and whether training finished. Loading
checks all of them and the tensor shapes, and refuses anything that does not fit with a
one-line :class:`ScdpError`.
"""

from __future__ import annotations

import json
from pathlib import Path

import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file

from scdp.config import DiffusionConfig, EncoderConfig, StyleConfig
from scdp.errors import ScdpError
from scdp.io import atomic_path, write_json
from scdp.models.scene_encoder import SceneAutoencoder
from scdp.models.style_predictor import StylePredictor
from scdp.models.unet1d import count_parameters
from scdp.policies.diffusion import DiffusionPolicy
from scdp.policies.normalizer import Normalizer

FORMAT_VERSION = 1
PARTS = ("base", "ld", "encoder", "style_legible", "style_efficient")


def save_tensors(path: Path, tensors: dict[str, torch.Tensor]) -> None:
    with atomic_path(path) as tmp:
        save_file({k: v.detach().contiguous().cpu() for k, v in tensors.items()}, str(tmp))


def load_tensors(path: Path, field: str) -> dict[str, torch.Tensor]:
    if not path.exists():
        raise ScdpError(field, f"{path} is missing")
    try:
        return load_file(str(path))
    except (SafetensorError, OSError, ValueError, RuntimeError) as exc:
        raise ScdpError(field, f"{path} is corrupt ({exc})") from None


def save_part(folder, module: torch.nn.Module, *, part: str, task: str, preset: str, config, normalizer=None,
              complete: bool = True, extra: dict | None = None) -> Path:
    """Write ``model.safetensors`` then ``config.json`` (each atomically)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    save_tensors(folder / "model.safetensors", module.state_dict())
    meta = {
        "format_version": FORMAT_VERSION, "part": part, "task": task, "preset": preset,
        "config": config.to_dict(), "normalizer": normalizer.to_dict() if normalizer else None,
        "parameters": count_parameters(module), "complete": complete, **(extra or {}),
    }
    write_json(folder / "config.json", meta)
    return folder


def read_meta(folder, part: str, task=None) -> dict:
    """Validated ``config.json`` of a part folder."""
    folder = Path(folder)
    path = folder / "config.json"
    if not path.exists():
        raise ScdpError(f"checkpoints/{part}", f"{folder} holds no {part} checkpoint (no config.json)")
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ScdpError(f"checkpoints/{part}", f"{path} is corrupt ({exc})") from None
    if meta.get("format_version") != FORMAT_VERSION:
        raise ScdpError(f"checkpoints/{part}", f"format version {meta.get('format_version')!r}, expected {FORMAT_VERSION}")
    if meta.get("part") != part:
        raise ScdpError(f"checkpoints/{part}", f"{folder} holds a {meta.get('part')!r} checkpoint")
    if task is not None and meta.get("task") != task.name:
        raise ScdpError("task", f"checkpoint {folder} was trained for {meta.get('task')!r}, not {task.name!r}")
    if not meta.get("complete", False):
        raise ScdpError(f"checkpoints/{part}", f"{folder} holds an unfinished training run (resume it with --resume)")
    return meta


def _load_into(module: torch.nn.Module, folder: Path, part: str) -> torch.nn.Module:
    state = load_tensors(folder / "model.safetensors", f"checkpoints/{part}")
    try:
        module.load_state_dict(state, strict=True)
    except RuntimeError as exc:
        first = str(exc).strip().splitlines()
        raise ScdpError(f"checkpoints/{part}", f"weights do not fit the config ({first[1].strip() if len(first) > 1 else first[0]})") from None
    return module.eval()


def load_diffusion(folder, task, part: str = "base") -> DiffusionPolicy:
    folder = Path(folder)
    meta = read_meta(folder, part, task)
    policy = DiffusionPolicy(DiffusionConfig.from_dict(meta["config"]), Normalizer.from_dict(meta["normalizer"]), task.task_space)
    return _load_into(policy, folder, part)


def load_encoder(folder, task) -> SceneAutoencoder:
    folder = Path(folder)
    meta = read_meta(folder, "encoder", task)
    return _load_into(SceneAutoencoder(EncoderConfig.from_dict(meta["config"])), folder, "encoder")


def load_style(folder, task, style: str) -> StylePredictor:
    folder = Path(folder)
    part = f"style_{style}"
    meta = read_meta(folder, part, task)
    return _load_into(StylePredictor(StyleConfig.from_dict(meta["config"])), folder, part)


def load_method(checkpoints, task, method: str, style: str = "auto", encoder_dir=None):
    """Build a planner for ``method`` (dp, ld or scdp) from a checkpoints folder.

    The scene encoder is ``checkpoints/encoder`` unless ``encoder_dir`` names another folder
    (the per-configuration model sets share their task's encoder).
    """
    from scdp.policies.legibility_diffuser import LegibilityDiffuser
    from scdp.policies.scdp import StyleConditionedPolicy

    root = Path(checkpoints)
    if not root.is_dir():
        raise ScdpError("--checkpoints", f"{root} is not a folder")
    if method == "dp":
        return load_diffusion(root / "base", task)
    if method == "ld":
        return LegibilityDiffuser(load_diffusion(root / "ld", task, part="ld"))
    if method == "scdp":
        base = load_diffusion(root / "base", task)
        encoder = load_encoder(root / "encoder" if encoder_dir is None else encoder_dir, task)
        wanted = ["legible", "efficient"] if style == "auto" else [s for s in (style,) if s != "none"]
        predictors = {s: load_style(root / f"style_{s}", task, s) for s in wanted}
        for name, pred in predictors.items():
            if pred.config.bottleneck_dim != base.unet.bottleneck_dim:
                raise ScdpError(f"checkpoints/style_{name}", f"made for a bottleneck of {pred.config.bottleneck_dim}, the base has {base.unet.bottleneck_dim}")
            if pred.config.context_dim != encoder.config.context_dim:
                raise ScdpError(f"checkpoints/style_{name}", f"expects context {pred.config.context_dim}, the encoder gives {encoder.config.context_dim}")
        return StyleConditionedPolicy(base, encoder, predictors, task, style=style)
    raise ScdpError("--method", f"unknown method {method!r} (dp, ld or scdp)")
