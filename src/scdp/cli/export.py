"""``scdp export``: each diffusion checkpoint's denoiser as ONNX, parity-checked (:mod:`scdp.policies.exported`)."""

from __future__ import annotations

from pathlib import Path

from scdp.errors import ScdpError
from scdp.io import check_output_path
from scdp.policies.checkpoint import read_meta
from scdp.policies.exported import ONNX_FILE, ONNX_META, export_denoiser
from scdp.policies.loaders import load_diffusion
from scdp.tasks import get_task

DIFFUSION_PARTS = ("base", "ld")  # the parts with a denoiser: DP's and SCDP's base, LD's goal-dropout base


def export(args) -> int:
    task = get_task(args.task)
    root = Path(args.checkpoints)
    if not root.is_dir():
        raise ScdpError("--checkpoints", f"{root} is not a folder")
    parts = [p for p in DIFFUSION_PARTS if (root / p / "config.json").is_file()]
    if not parts:
        raise ScdpError("--checkpoints", f"{root} holds no {' or '.join(DIFFUSION_PARTS)} checkpoint to export")
    for part in parts:  # nothing is replaced without --force, and nothing is written before every check
        for name in (ONNX_FILE, ONNX_META):
            check_output_path(root / part / name, force=args.force, field="checkpoints")
    for part in parts:
        folder = root / part
        policy = load_diffusion(folder, task, part)
        config = policy.config
        meta = export_denoiser(policy.unet, folder, horizon=config.horizon, state_dim=config.state_dim,
                               cond_dim=config.global_cond_dim, steps=config.num_train_timesteps,
                               extra={"part": part, "task": task.name, "sampler": config.sampler,
                                      "num_inference_steps": config.num_inference_steps,
                                      "normalizer": read_meta(folder, part, task).get("normalizer")})
        print(f"exported {folder / ONNX_FILE}: parity with torch {meta['parity']['max_abs_error']:.2g} "
              f"(tolerance {meta['parity']['tolerance']:g})")
    return 0
