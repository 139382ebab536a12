"""The parser's argument types: every numeric range of a flag, checked as the command line is read.

A value out of range raises :class:`argparse.ArgumentTypeError`; the parser
(:class:`scdp.cli.parser._Parser`) turns it into the one line ``scdp: error: <flag>: <problem>`` with exit
status 2, before any handler module is imported. Text that is no number at all keeps argparse's own
``invalid int value: 'x'``. Standard library and scdp's light leaves only, as the parser.
"""

from __future__ import annotations

import argparse

from scdp.config.planning import PlannerSpec
from scdp.errors import ScdpError
from scdp.messages import preview

MAX_THREADS = 4096  # a larger pool is a typo: OpenMP would try to start them all
MAX_COUNT = 1_000_000  # demos or scenes in one command: more is a typo, not a job for 2 cores


def _n(value: int) -> str:
    """65535, but 1,000,000: thousands separated from six digits on."""
    return f"{value:,}" if abs(value) >= 100_000 else str(value)


def int_in(lo: int | None = None, hi: int | None = None):
    """An int from ``lo`` to ``hi`` (either end ``None``: unbounded), e.g. ``type=int_in(0, 65535)``."""
    if lo is not None and hi is not None:
        problem = f"must be from {_n(lo)} to {_n(hi)}"
    else:
        problem = f"must be >= {_n(lo)}" if lo is not None else f"must be at most {_n(hi)}"

    def parse(text: str) -> int:
        value = int(text)  # a ValueError is argparse's "invalid int value: 'x'"
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"{problem}, got {_n(value)}")
        return value

    parse.__name__ = "int"
    return parse


def float_in(lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False, unit: str = ""):
    """A float in the interval from ``lo`` to ``hi``, each end closed unless ``*_open``; NaN is refused."""
    interval = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}" + (f" {unit}" if unit else "")

    def parse(text: str) -> float:
        value = float(text)  # a ValueError is argparse's "invalid float value: 'x'"
        above = value > lo if lo_open else value >= lo
        below = value < hi if hi_open else value <= hi
        if not (above and below):  # NaN fails both
            raise argparse.ArgumentTypeError(f"must be in {interval}, got {value:g}")
        return value

    parse.__name__ = "float"
    return parse


seed = int_in(0)  # every --seed: a seed is >= 0
count = int_in(1, MAX_COUNT)  # demos or scenes: 0 draws nothing
port = int_in(0, 65535)  # 0: a free port


def point(text: str):
    """``1.5,0.2`` -> [1.5, 0.2] (an argparse type)."""
    try:
        return [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers like 1.5,0.2, got {preview(text)}") from None


def method_spec(text: str) -> PlannerSpec:
    """``dp``, ``scdp_blend`` or ``scdp:legible`` -> its :class:`PlannerSpec` (an argparse type)."""
    try:
        return PlannerSpec.parse(text)
    except ScdpError as err:
        raise argparse.ArgumentTypeError(err.message) from None
