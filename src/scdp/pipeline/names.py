"""The names of ``scdp reproduce``'s stages, and of their compute times: made and read here only.

A stage's name says what it makes and for which model set::

    ambiguity, encoder                       what every model set of a task needs
    demos, base, style_legible, ..., ld      the task's random-scene model set
    evaluate                                 the random-scene evaluation
    per_layout/layout_2/demos, .../base      one per-layout model set
    per_layout/evaluate                      the per-layout evaluation

It is written that way in the log, in a stage's lock file and in ``stage_times.json`` (there as
``<task>/<stage>``). :class:`StageName` is such a string that keeps its parts, so no other module
splits one (``tests/test_stage_names.py``).
"""

from __future__ import annotations

from scdp.errors import ScdpError
from scdp.keys import PER_LAYOUT, RANDOM

SEP = "/"


class StageName(str):
    """A stage's name (a ``str``, as the log and files write it) with its parts: ``what`` it makes,
    the ``protocol`` of its model set (``random`` or ``per_layout``) and the per-layout model set's
    ``layout`` (``layout_2``; None for a stage of the whole protocol, as its evaluation)."""

    what: str
    protocol: str
    layout: str | None

    def __new__(cls, what: str, protocol: str = RANDOM, layout: str | None = None) -> StageName:
        if protocol not in (RANDOM, PER_LAYOUT) or (layout is not None and protocol != PER_LAYOUT):
            raise ScdpError("stage", f"no stage {what!r} of protocol {protocol!r}, layout {layout!r}")
        text = what if protocol == RANDOM else SEP.join(p for p in (PER_LAYOUT, layout, what) if p)
        name = super().__new__(cls, text)
        name.what, name.protocol, name.layout = what, protocol, layout
        return name

    def __getnewargs__(self):  # pickled (to a Ray worker) as its parts
        return self.what, self.protocol, self.layout

    @classmethod
    def parse(cls, text: str) -> StageName:
        """The name as the files write it back into its parts; anything else is refused."""
        parts = text.split(SEP)
        if len(parts) == 1 and parts[0]:
            return cls(parts[0])
        if parts[0] == PER_LAYOUT and len(parts) in (2, 3) and all(parts):
            return cls(parts[-1], PER_LAYOUT, parts[1] if len(parts) == 3 else None)
        raise ScdpError("stage", f"{text!r} is not a stage's name")

    @property
    def model_set(self) -> str:
        """The model set's folder under the task's, as the log names a unit: ``per_layout/layout_2``, or
        ``models`` for the random-scene set."""
        return SEP.join((PER_LAYOUT, self.layout)) if self.layout else "models"

    @property
    def file_stem(self) -> str:
        """The name as one path component (the lock file's): ``per_layout--layout_2--base``."""
        return self.replace(SEP, "--")

    def timed(self, task: str) -> str:
        """Its key in ``stage_times.json``: ``<task>/<stage>``."""
        return SEP.join((task, self))


def evaluation_key(task: str, protocol: str) -> str:
    """An evaluation's key in ``results.json``'s ``evaluations``: ``<task>/<protocol>``."""
    return SEP.join((task, protocol))


def parse_timed(key: str) -> tuple[str, StageName]:
    """A ``stage_times.json`` key as (task, stage name)."""
    task, _, stage = key.partition(SEP)
    return task, StageName.parse(stage)
