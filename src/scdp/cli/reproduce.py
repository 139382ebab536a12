"""``scdp reproduce``: the main job; ``scdp report``: its report files again from a ``results.json``."""

from __future__ import annotations

from pathlib import Path

from scdp.cli.options import goal_overrides
from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError, refuse_repeats
from scdp.io import check_output_path
from scdp.keys import RANDOM
from scdp.pipeline.executor import make_executor
from scdp.pipeline.report import REPORT_FILES, rebuild_report
from scdp.pipeline.run import reproduce as run_reproduction
from scdp.pipeline.run import stale_stages
from scdp.presets import get_preset


def reproduce(args) -> int:
    if args.layouts is not None:  # a repeated layout would be dropped, and the random protocol trains none
        refuse_repeats(args.layouts, "--layouts")
        if args.protocol == RANDOM:
            raise ScdpError("--layouts", "picks the per-layout model sets; pass --protocol per_layout or both with it")
    preset = get_preset(args.preset, goal_overrides(args)).with_training_seed(args.seed)
    if args.seeds is not None:
        refuse_repeats(args.seeds, "--seeds")
    if args.dry_run:
        runs = ({Path(args.out): preset} if args.seeds is None
                else {Path(args.out) / f"seed_{k}": preset.with_training_seed(k) for k in args.seeds})
        stale = [(folder, *row) for folder, p in runs.items()
                 for row in stale_stages(args.task, p, folder, protocol=args.protocol, layouts=args.layouts)]
        for folder, task, stage, changed in stale:
            where = f"{folder.name} " if args.seeds is not None else ""
            print(f"[{where}{task}] {stage}: would be redone ({', '.join(changed)})")
        print(f"{len(stale)} stage(s) would be redone" if stale else f"{args.out} is up to date: nothing would be redone")
        return 0
    executor = make_executor(args.executor, address=args.ray_address, workers=args.workers)
    run_reproduction(args.task, preset, args.out, protocol=args.protocol, layouts=args.layouts, command=args.command_line,
                     device=resolve_device(args.device), adopt=args.adopt, seeds=args.seeds, executor=executor)
    return 0


def report(args) -> int:
    results = Path(args.results)
    if not results.is_file():
        raise ScdpError("results", f"{results} is not a file (a results.json written by scdp reproduce)")
    out = Path(args.out) if args.out else results.parent
    for name in REPORT_FILES:  # nothing is replaced without --force
        check_output_path(out / name, force=args.force)
    written = rebuild_report(results, out, figures=not args.no_figures, confidence=args.confidence)
    print(f"report rebuilt from {results} -> {written['report']}, {written['claims']}")
    return 0
