"""``scdp train``: one part into its own checkpoint folder."""

from __future__ import annotations

import json
import os
from pathlib import Path

from scdp.presets import get_preset
from scdp.data.dataset import DemoDataset
from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError
from scdp.policies.checkpoint import check_checkpoint_folder
from scdp.tasks import get_task
from scdp.training import parts


def train(args) -> int:
    task, preset = get_task(args.task), get_preset(args.preset, args.overrides)
    if args.dry_run:
        print(json.dumps(parts.dry_run(task, preset, args.part)))
        return 0
    if not args.out:
        raise ScdpError("--out", "required unless --dry-run")
    out = check_checkpoint_folder(args.out)
    device = resolve_device(args.device)
    if (out / "config.json").exists() and not (args.resume or args.force):
        raise ScdpError("--out", f"{out} already holds a checkpoint (pass --resume to continue or --force to retrain)")
    if args.part == "encoder":
        _, result = parts.train_encoder(task, preset, out, resume=args.resume, device=device)
    else:
        if not args.data:
            raise ScdpError("--data", f"training {args.part} needs demonstrations")
        dataset = DemoDataset.load(args.data)
        base = Path(args.base) if args.base else out.parent / "base"
        if args.part in ("base", "ld"):
            _, result = parts.train_diffusion(task, dataset, preset, out, ld=args.part == "ld", resume=args.resume,
                                              device=device, base_dir=base)
        else:
            encoder = Path(args.encoder) if args.encoder else out.parent / "encoder"
            part = f"style_paper_{args.style}" if args.design == "paper" else f"style_{args.style}"
            _, result = parts.train_style(task, dataset, part, preset, base, encoder, out, resume=args.resume,
                                          device=device)
    if int(os.environ.get("RANK", "0")) == 0:  # under `accelerate launch`, the main process reports
        print(f"trained {args.part} for {result.steps} steps (final epoch loss {result.losses[-1]:.5f}) -> {out}")
    return 0
