"""How bad values appear in error messages: short, and on one line.

Used by the command line (``scdp: error: <field>: <problem>``) and by the planning service
(``{"error": "<field>: <problem>"}``). Standard library only, so ``scdp --help`` stays instant.
"""

from __future__ import annotations

PREVIEW_CHARS = 40  # of a bad value echoed back in a message
MAX_MESSAGE_CHARS = 600  # of a whole error line


def preview(value, limit: int = PREVIEW_CHARS) -> str:
    """``repr(value)``, cut to ``limit`` characters (with ``...`` and the full length when cut), so a
    1 MB string is never echoed back."""
    text = repr(value)
    if len(text) <= limit:
        return text
    size = f" ({len(value):,} characters)" if isinstance(value, (str, bytes)) else ""
    return text[:limit] + "..." + size


def one_line(text: str, limit: int = MAX_MESSAGE_CHARS) -> str:
    """``text`` with line breaks and other control characters escaped (a newline inside a path
    must not split the error line), cut to ``limit`` characters."""
    out = "".join(ch if ch.isprintable() or ch == " " else ascii(ch)[1:-1] for ch in str(text))
    return out if len(out) <= limit else out[:limit] + "..."
