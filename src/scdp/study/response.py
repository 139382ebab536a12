"""One confirmed trial, typed: the columns of the store's ``responses`` table, named once.

The server builds a :class:`Response` when a participant confirms a trial
(:meth:`scdp.study.server.StudyServer.confirm`); the store's table is made from its fields
(:func:`response_columns`), and writes and reads it (:meth:`scdp.study.store.Store.record`). The
JSON fields (:data:`JSON_FIELDS`) are stored as text.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass

from sqlalchemy import Boolean, Column, Float, ForeignKey, Integer, String, Text

JSON_FIELDS = ("colours", "goal_order", "events")  # stored as JSON text


@dataclass(frozen=True)
class Response:
    """A participant's confirmed answer to one trial, and how the trial went."""

    pid: str
    trial: int
    stimulus: str
    kind: str  # practice, main, attention, instructed
    mirror: bool
    colours: list  # the palette index of each served position
    goal_order: list  # the stimulus's goal at each served position (button order)
    choice: int  # the stimulus's goal index confirmed
    correct: bool
    events: list  # [{"t": server's fraction, "client_t", "s": server's seconds, "goal"}], the picks in order
    served: float  # when the trial was first served (server's clock)
    played: float  # when its motion started
    confirmed: float
    loads: int  # how often the page received it
    replays: int  # loads while (or after) the motion played
    target_position: int  # the button of the goal the motion went to
    choice_position: int  # the button confirmed
    instructed: int | None  # instructed checks: the button the participant was told to choose
    confidence: int  # 1 (a guess) .. 5 (certain)
    hidden: int  # the page was hidden (tab switched) while the motion played
    blurs: int  # the window lost focus while the motion played
    refused: int  # picks refused: over the cap or too fast

    def row(self) -> dict:
        """The table row: the JSON fields as text."""
        return {k: json.dumps(v) if k in JSON_FIELDS else v for k, v in dataclasses.asdict(self).items()}


_SQL = {"str": String(128), "int": Integer, "bool": Boolean, "float": Float, "list": Text, "int | None": Integer}


def response_columns() -> list[Column]:
    """The ``responses`` table's columns, one per :class:`Response` field: (pid, trial) the key, pid a
    participant's; every column required but ``instructed``."""
    columns = []
    for f in dataclasses.fields(Response):
        if f.name == "pid":
            columns.append(Column("pid", String(64), ForeignKey("participants.pid", ondelete="CASCADE"), primary_key=True))
        elif f.name == "trial":
            columns.append(Column("trial", Integer, primary_key=True))
        else:
            columns.append(Column(f.name, _SQL[f.type], nullable=f.type.endswith("None")))
    return columns
