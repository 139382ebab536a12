"""The one rule that picks a setting from a validation sweep, for every method alike.

Among the settings whose success is at least :data:`MIN_SUCCESS` in every task and scene set,
take the one with the highest failure-aware transparency ``T_fa``
(:func:`scdp.metrics.failure_aware_transparency`) averaged over tasks and over the ambiguous
and clear validation sets; when no setting reaches that success, take the most successful one
(ties: the higher mean ``T_fa``). Legibility Diffuser's guidance (``benchmarks/ld_sweep.py``) is
chosen by it; it is written down here so that SCDP's options can be judged by the same words.
"""

from __future__ import annotations

from scdp.metrics import MIN_SUCCESS


def choose(rows: list[dict]) -> tuple[dict, bool]:
    """The chosen row and whether it meets :data:`MIN_SUCCESS`. Each row has ``min_success`` (the
    lowest success over tasks and scene sets) and ``mean_T_fa`` (the mean over them)."""
    if not rows:
        raise ValueError("no settings to choose from")
    ok = [r for r in rows if r["min_success"] >= MIN_SUCCESS]
    if ok:
        return max(ok, key=lambda r: r["mean_T_fa"]), True
    return max(rows, key=lambda r: (r["min_success"], r["mean_T_fa"])), False
