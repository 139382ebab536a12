"""``scdp verify``: a run's verdicts beside the committed ones (:mod:`scdp.pipeline.verify`)."""

from __future__ import annotations

from scdp.devices import resolve as resolve_device
from scdp.io import check_output_path, write_json
from scdp.pipeline.verify import verify as run_verify
from scdp.pipeline.verify import verify_markdown


def verify(args) -> int:
    out = check_output_path(args.out, force=args.force) if args.out else None
    report = run_verify(args.run, args.against, scenes=args.scenes, seed=args.seed, device=str(resolve_device(args.device)))
    print(verify_markdown(report), end="")
    if out is not None:
        write_json(out, report)
    return 0
