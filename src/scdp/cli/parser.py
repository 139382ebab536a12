"""The ``scdp`` argument parser: every command, its options and its help text.

It imports only the standard library and scdp's light leaves (keys, errors, messages, config), so
``scdp --help`` is instant. The commands are defined by subject: :mod:`~scdp.cli.parser_data`,
:mod:`~scdp.cli.parser_models`, :mod:`~scdp.cli.parser_runs`, :mod:`~scdp.cli.parser_serve` and
:mod:`~scdp.cli.study_parser`, with the flags they share in :mod:`~scdp.cli.parser_common` and every
numeric range as an argparse type in :mod:`~scdp.cli.types`; :func:`build_parser` assembles them.
Each subparser names its handler as ``"module:function"`` inside :mod:`scdp.cli`.
"""

from __future__ import annotations

import argparse
import re

from scdp.cli import types
from scdp.cli.parser_data import add_data_parsers
from scdp.cli.parser_models import add_model_parsers
from scdp.cli.parser_runs import add_run_parsers
from scdp.cli.parser_serve import add_serve_parsers
from scdp.cli.study_parser import add_study_parsers
from scdp.errors import ScdpError
from scdp.messages import PREVIEW_CHARS, preview


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line naming the argument (a long quoted value cut short)."""

    def error(self, message):
        message = re.sub(r"'([^']{%d,})'" % PREVIEW_CHARS, lambda m: preview(m.group(1)), message)
        match = re.match(r"argument ([^:]+): (.*)", message)
        if match:
            field = match.group(1)
            raise ScdpError("command" if field.startswith("<") else field, match.group(2))  # <command>: the subcommand
        match = re.match(r"the following arguments are required: (.+)", message)
        if match:  # the first missing argument is the field
            missing = match.group(1).split(", ")
            others = f"; also missing: {', '.join(missing[1:])}" if len(missing) > 1 else ""
            raise ScdpError(missing[0].split("/")[0], f"required{others} (see {self.prog} --help)")
        raise ScdpError(self.prog, message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="scdp",
        description="Style-Conditioned Diffusion Policy: demonstrations, metrics, ambiguity and the paper's reproduction.",
        epilog="Start with `scdp reproduce --task navigation --preset cpu --out runs/cpu`, "
        "or `scdp generate --task navigation --num-demos 200 --seed 0 --out demos.zarr`.",
    )
    parser.add_argument("--threads", type=types.int_in(hi=types.MAX_THREADS), default=None, metavar="N",
                        help="CPU threads for torch (default: torch's choice, or OMP_NUM_THREADS). Idle threads "
                             "sleep rather than spin, so scdp shares cores gracefully (see scdp.threads)")
    sub = parser.add_subparsers(dest="command", metavar="<command>", parser_class=_Parser)
    for add in (add_data_parsers, add_model_parsers, add_run_parsers, add_serve_parsers, add_study_parsers):
        add(sub)  # in this order, as scdp --help lists them
    return parser
