"""The ``scdp`` command line. Run ``scdp --help`` or ``scdp <command> --help``.

Every command validates its input first; a bad value is reported as one line
``scdp: error: <field>: <problem>`` with exit status 2, and nothing is written. The line stays one
line (control characters in a path are escaped, long values cut: :mod:`scdp.messages`), and
numeric RuntimeWarnings (overflow, invalid values) raised on the way to a refusal are dropped with
it: they would only repeat its cause. A command that succeeds shows them after it finishes.

The parser (:mod:`scdp.cli.parser`) needs neither torch nor MuJoCo. Each command lives in a
small handler module (the parsers name each one: ``handler="module:function"``, e.g. ``plan``,
``serve`` or ``study``) that imports what it needs at its top; ``main`` loads only the one module the
command names, so ``scdp --help`` and ``scdp plan`` pay for no imports they do not use.
"""

from __future__ import annotations

import importlib
import sys
import warnings
from pathlib import Path

from scdp import threads
from scdp.cli.parser import build_parser
from scdp.errors import ScdpError
from scdp.messages import one_line, preview

OPTIONAL_MODULES = {"pyarrow": "lerobot", "playwright": "study"}  # a module an extra installs -> the extra
EXIT_BAD_INPUT = 2
IMAGE_COMMANDS = ("plot-demos", "plot-ellipse")
IMAGE_SUFFIXES = (".png", ".pdf", ".svg")


class _HeldRuntimeWarnings:
    """Hold RuntimeWarnings back while a command runs (other warnings show at once). On success they
    are shown after all (:meth:`release`); on a refusal they are dropped with the error they led to."""

    def __init__(self):
        self.held: list = []
        self.shown = None

    def _hold(self, message, category, filename, lineno, file=None, line=None):
        if issubclass(category, RuntimeWarning):
            self.held.append((message, category, filename, lineno, file, line))
        else:
            self.shown(message, category, filename, lineno, file, line)

    def __enter__(self):
        self.shown, warnings.showwarning = warnings.showwarning, self._hold
        return self

    def release(self, show: bool = True) -> None:
        """Stop holding; show what was held (unless ``show`` is false)."""
        if self.shown is not None:
            warnings.showwarning, self.shown = self.shown, None
            for args in self.held if show else ():
                warnings.showwarning(*args)
            self.held = []

    def __exit__(self, kind, value, traceback):
        self.release(show=kind is not None)  # a crash keeps its warnings: they may explain it


def _error(field_and_problem: str) -> int:
    print(f"scdp: error: {one_line(field_and_problem)}", file=sys.stderr)
    return EXIT_BAD_INPUT


def main(argv=None) -> int:
    with _HeldRuntimeWarnings() as hold:
        code = _main(argv, hold)
        hold.release(show=code == 0)
    return code


def _main(argv, hold: _HeldRuntimeWarnings) -> int:
    parser = build_parser()
    try:
        argv = sys.argv[1:] if argv is None else list(argv)
        args = parser.parse_args(argv)
        args.command_line = " ".join(["scdp", *argv])
        if not getattr(args, "handler", None):
            parser.print_help()
            return EXIT_BAD_INPUT
        out = getattr(args, "out", None)
        if out is not None and not str(out).strip():
            raise ScdpError("--out", "must not be empty")
        if args.command in IMAGE_COMMANDS and Path(out).suffix.lower() not in IMAGE_SUFFIXES:
            raise ScdpError("--out", f"must end in {' or '.join(IMAGE_SUFFIXES)}, got {preview(Path(out).name)}")
        threads.configure(args.threads)  # before the handler module imports torch
        if args.command == "serve" or getattr(args, "study_command", None) == "serve":
            hold.release()  # it runs until stopped: its warnings belong in its log, as they come
        module, function = args.handler.split(":")
        try:
            handler = getattr(importlib.import_module(f"scdp.cli.{module}"), function)
        except ModuleNotFoundError as exc:  # a command of an extra that is not installed
            extra = OPTIONAL_MODULES.get((exc.name or "").split(".")[0])
            if extra is None:
                raise
            raise ScdpError(args.command, f"needs {exc.name}: pip install 'scdp[{extra}]'") from None
        return handler(args)
    except ScdpError as exc:
        return _error(str(exc))
    except OSError as exc:  # disk full, permissions changed mid-run, ...
        return _error(f"{getattr(exc, 'filename', None) or 'io'}: {exc.strerror or exc}")
    except KeyboardInterrupt:
        print("scdp: interrupted", file=sys.stderr)
        return 130
