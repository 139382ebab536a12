"""``scdp reproduce``: the main job."""

from __future__ import annotations

from scdp.config import get_preset
from scdp.pipeline.run import reproduce as run_reproduction


def reproduce(args) -> int:
    preset = get_preset(args.preset, args.overrides)
    run_reproduction(args.task, preset, args.out, protocol=args.protocol, layouts=args.layouts, command=args.command_line)
    return 0
