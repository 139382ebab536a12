"""The ``scdp`` command line. Run ``scdp --help`` or ``scdp <command> --help``.

Every command validates its input first; a bad value is reported as one line
``scdp: error: <field>: <problem>`` with exit status 2, and nothing is written.

The parser (:mod:`scdp.cli.parser`) needs neither torch nor MuJoCo. Each command lives in a
small handler module (``data``, ``ambiguity``, ``train``, ``plan``, ``evaluate``,
``reproduce``) that imports what it needs at its top; ``main`` loads only the one module the
command names, so ``scdp --help`` and ``scdp plan`` pay for no imports they do not use.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

from scdp import threads
from scdp.cli.parser import build_parser
from scdp.errors import ScdpError

EXIT_BAD_INPUT = 2
MAX_COUNT = 1_000_000  # demos or scenes in one command: more is a typo, not a job for 2 cores
IMAGE_COMMANDS = ("plot-demos", "plot-ellipse")
IMAGE_SUFFIXES = (".png", ".pdf", ".svg")


def main(argv=None) -> int:
    parser = build_parser()
    try:
        argv = sys.argv[1:] if argv is None else list(argv)
        args = parser.parse_args(argv)
        args.command_line = " ".join(["scdp", *argv])
        if not getattr(args, "handler", None):
            parser.print_help()
            return EXIT_BAD_INPUT
        for name in ("num_demos", "scenes", "max_demos", "seed"):
            value = getattr(args, name, None)
            if isinstance(value, int) and value < 0:
                raise ScdpError("--" + name.replace("_", "-"), f"must be >= 0, got {value}")
        for name, limit in (("num_demos", MAX_COUNT), ("scenes", MAX_COUNT)):
            value = getattr(args, name, None)
            if isinstance(value, int) and not 1 <= value <= limit:
                raise ScdpError("--" + name.replace("_", "-"), f"must be from 1 to {limit:,}, got {value:,}")
        out = getattr(args, "out", None)
        if out is not None and not str(out).strip():
            raise ScdpError("--out", "must not be empty")
        if args.command in IMAGE_COMMANDS and Path(out).suffix.lower() not in IMAGE_SUFFIXES:
            raise ScdpError("--out", f"must end in {' or '.join(IMAGE_SUFFIXES)}, got {Path(out).name!r}")
        threads.configure(args.threads)  # before the handler module imports torch
        module, function = args.handler.split(":")
        return getattr(importlib.import_module(f"scdp.cli.{module}"), function)(args)
    except ScdpError as exc:
        print(f"scdp: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # disk full, permissions changed mid-run, ...
        print(f"scdp: error: {getattr(exc, 'filename', None) or 'io'}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("scdp: interrupted", file=sys.stderr)
        return 130
