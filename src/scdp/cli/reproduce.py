"""``scdp reproduce``: the main job."""

from __future__ import annotations

from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError, refuse_repeats
from scdp.keys import RANDOM
from scdp.pipeline.run import reproduce as run_reproduction
from scdp.presets import get_preset


def reproduce(args) -> int:
    if args.seed < 0:
        raise ScdpError("--seed", f"must be >= 0, got {args.seed}")
    if args.layouts is not None:  # a repeated layout would be dropped, and the random protocol trains none
        refuse_repeats(args.layouts, "--layouts")
        if args.protocol == RANDOM:
            raise ScdpError("--layouts", "picks the per-layout model sets; pass --protocol per_layout or both with it")
    preset = get_preset(args.preset, args.overrides).with_training_seed(args.seed)
    run_reproduction(args.task, preset, args.out, protocol=args.protocol, layouts=args.layouts, command=args.command_line,
                     device=resolve_device(args.device))
    return 0
