"""``scdp train``: one part into its own checkpoint folder."""

from __future__ import annotations

import json
import os
from pathlib import Path

from scdp.cli.options import goal_overrides
from scdp.data.dataset import DemoDataset
from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError
from scdp.keys import PAPER_METHOD, style_part
from scdp.policies.checkpoint import check_checkpoint_folder
from scdp.presets import get_preset
from scdp.tasks import get_task
from scdp.training import parts


def _found_run(out: Path) -> tuple[str, str] | None:
    """(part, task) recorded in ``out/config.json`` (finished or not), or None where none is readable."""
    try:
        meta = json.loads((out / "config.json").read_text())
    except (OSError, ValueError):
        return None
    return (str(meta.get("part")), str(meta.get("task"))) if isinstance(meta, dict) else None


def check_same_run(out: Path, part: str, task: str, *, resume: bool, force: bool) -> None:
    """Refuse to resume, or to train without ``--force``, into a folder holding another part's or
    another task's run, naming what it holds: the advice to start afresh with --force would
    overwrite someone else's run."""
    found = _found_run(out)
    if found is None or found == (part, task) or (force and not resume):
        return
    what = f"{out} holds a {found[0]!r} run of task {found[1]!r}, not {part!r} of {task!r}"
    if resume:
        raise ScdpError("--resume", f"{what}; resume it with its own part and task, or train into another --out")
    raise ScdpError("--out", f"{what}; choose another --out")


def train(args) -> int:
    task, preset = get_task(args.task), get_preset(args.preset, goal_overrides(args))
    if args.dry_run:
        print(json.dumps(parts.dry_run(task, preset, args.part)))
        return 0
    if not args.out:
        raise ScdpError("--out", "required unless --dry-run")
    out = check_checkpoint_folder(args.out)
    device = resolve_device(args.device)
    part = args.part
    if part == "style":
        part = style_part(args.style, PAPER_METHOD if args.design == "paper" else "scdp")
    check_same_run(out, part, task.name, resume=args.resume, force=args.force)
    if (out / "config.json").exists() and not (args.resume or args.force):
        raise ScdpError("--out", f"{out} already holds a checkpoint (pass --resume to continue or --force to retrain)")
    dataset = None
    if args.part != "encoder":
        if not args.data:
            raise ScdpError("--data", f"training {args.part} needs demonstrations")
        dataset = DemoDataset.load(args.data)
    base = Path(args.base) if args.base else out.parent / "base"
    encoder = Path(args.encoder) if args.encoder else out.parent / "encoder"
    _, result = parts.train_part(task, preset, part, out, dataset=dataset, base_dir=base, encoder_dir=encoder,
                                 resume=args.resume, device=device)
    if int(os.environ.get("RANK", "0")) == 0:  # under `accelerate launch`, the main process reports
        print(f"trained {args.part} for {result.steps} steps (final epoch loss {result.losses[-1]:.5f}) -> {out}")
    return 0
