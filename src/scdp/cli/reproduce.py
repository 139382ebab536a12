"""``scdp reproduce``: the main job."""

from __future__ import annotations

from scdp.devices import resolve as resolve_device
from scdp.presets import get_preset
from scdp.errors import ScdpError
from scdp.pipeline.run import reproduce as run_reproduction


def reproduce(args) -> int:
    if args.seed < 0:
        raise ScdpError("--seed", f"must be >= 0, got {args.seed}")
    preset = get_preset(args.preset, args.overrides).with_training_seed(args.seed)
    run_reproduction(args.task, preset, args.out, protocol=args.protocol, layouts=args.layouts, command=args.command_line,
                     device=resolve_device(args.device))
    return 0
