"""Short forms the command handlers print (``scdp plan``, ``scdp deploy``)."""

from __future__ import annotations


def style_runs(styles: list[str]) -> str:
    """'legible x2, efficient x9': the style of consecutive chunks, run-length encoded."""
    runs: list[list] = []
    for s in styles:
        if runs and runs[-1][0] == s:
            runs[-1][1] += 1
        else:
            runs.append([s, 1])
    return ", ".join(f"{s} x{n}" for s, n in runs)
