"""One error type for every bad input, and the small checks that raise it.

Every user-facing failure in scdp is a :class:`ScdpError` that names the
offending field. The CLI prints it as a single line and exits non-zero; library
users can catch it like any ``ValueError``.
"""

from __future__ import annotations

import numpy as np

from scdp.messages import preview


class ScdpError(ValueError):
    """A bad input, reported as ``<field>: <what is wrong>``."""

    def __init__(self, field: str, message: str):
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}")


def finite_array(value, field: str, shape_tail: tuple[int, ...] | None = None) -> np.ndarray:
    """Return ``value`` as a float64 array, refusing NaN/inf and wrong trailing shapes."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ScdpError(field, f"not numeric ({exc})") from None
    if shape_tail is not None and arr.shape[-len(shape_tail):] != shape_tail:
        raise ScdpError(field, f"expected trailing shape {shape_tail}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ScdpError(field, "contains NaN or inf")
    return arr


def non_negative_int(value, field: str) -> int:
    """Return ``value`` as an int >= 0."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ScdpError(field, f"must be an integer, got {value!r}")
    if value < 0:
        raise ScdpError(field, f"must be >= 0, got {value}")
    return int(value)


def refuse_repeats(names, field: str, same=lambda name: name) -> None:
    """Refuse a list that names one thing twice (``same`` maps a name to what it stands for)."""
    seen: dict = {}
    for name in names:
        key = same(name)
        if key in seen:
            shown = (f"{preview(name)} twice" if seen[key] == name
                     else f"{preview(seen[key])} and {preview(name)}, the same planner")
            raise ScdpError(field, f"lists {shown}; give each once")
        seen[key] = name
