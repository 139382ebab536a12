"""Export a checkpoints folder's denoisers as ONNX: the library call behind ``scdp export``."""

from __future__ import annotations

from pathlib import Path

from scdp.errors import ScdpError
from scdp.io import check_output_path
from scdp.keys import STUDENT_PART
from scdp.policies.checkpoint import EXPORTED_FILES, read_meta
from scdp.policies.exported import export_denoiser
from scdp.policies.loaders import load_diffusion
from scdp.tasks import Task

# the parts with a denoiser: DP's and SCDP's base, LD's goal-dropout base, the few-step student
DIFFUSION_PARTS = ("base", "ld", STUDENT_PART)


def export_checkpoints(checkpoints, task: Task, *, force: bool = False, only: tuple[str, ...] | None = None) -> dict[str, dict]:
    """Export the denoiser of each diffusion part in ``checkpoints`` (:func:`export_denoiser`), or of the
    parts ``only`` names, bound to the weights it came from; ``{part: the graph's metadata}``. Nothing is
    replaced without ``force``, and nothing is written before every part has been checked."""
    root = Path(checkpoints)
    if not root.is_dir():
        raise ScdpError("--checkpoints", f"{root} is not a folder")
    unknown = sorted(set(only or ()) - set(DIFFUSION_PARTS))
    if unknown:
        raise ScdpError("--parts", f"{', '.join(unknown)}: not a diffusion part (choose from {', '.join(DIFFUSION_PARTS)})")
    missing = [p for p in only or () if not (root / p / "config.json").is_file()]
    if missing:
        raise ScdpError("--parts", f"{root} holds no {', '.join(missing)} checkpoint")
    parts = [p for p in DIFFUSION_PARTS if (root / p / "config.json").is_file() and (only is None or p in only)]
    if not parts:
        raise ScdpError("--checkpoints", f"{root} holds no {' or '.join(DIFFUSION_PARTS)} checkpoint to export")
    for part in parts:
        for name in EXPORTED_FILES:
            check_output_path(root / part / name, force=force, field="checkpoints")
    exported = {}
    for part in parts:
        folder = root / part
        config = (policy := load_diffusion(folder, task, part)).config
        exported[part] = export_denoiser(policy.unet, folder, horizon=config.horizon, state_dim=config.state_dim,
                                         cond_dim=config.global_cond_dim, steps=config.num_train_timesteps,
                                         extra={"part": part, "task": task.name, "sampler": config.sampler,
                                                "num_inference_steps": config.num_inference_steps,
                                                "normalizer": read_meta(folder, part, task).get("normalizer")})
    return exported
