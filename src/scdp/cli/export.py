"""``scdp export``: each diffusion checkpoint's denoiser as ONNX, parity-checked (:mod:`scdp.policies.export`)."""

from __future__ import annotations

from pathlib import Path

from scdp.policies.checkpoint import ONNX_FILE
from scdp.policies.export import export_checkpoints
from scdp.tasks import get_task


def export(args) -> int:
    only = tuple(args.parts) if args.parts else None
    for part, meta in export_checkpoints(args.checkpoints, get_task(args.task), force=args.force, only=only).items():
        print(f"exported {Path(args.checkpoints) / part / ONNX_FILE}: parity with torch {meta['parity']['max_abs_error']:.2g} "
              f"(tolerance {meta['parity']['tolerance']:g}), bound to weights {meta['weights_sha256'][:12]}")
    return 0
