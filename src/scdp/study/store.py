"""Where a study's responses live: a SQL database through SQLAlchemy (SQLite by default).

Two tables. ``participants``: the ID a participant arrived with, their arrival number (which
decides their trials, :func:`scdp.study.design.assignment`), when they consented and finished.
``responses``: one row per confirmed trial, keyed by (participant, trial), with every goal they
picked on the way (``events``: ``[{"t": fraction of the motion shown, "goal": index}]``).

Every write is one transaction, committed before the server answers, so a confirmed response
survives the server being killed at any later moment; SQLite runs with its default full
synchronisation. A second response to the same trial violates the primary key and is refused;
nothing stored changes. What is stored about a person is the ID the recruiting platform passed
and their answers, nothing else (no IP address, no browser details): :meth:`Store.delete`
removes a participant entirely.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from sqlalchemy import (Boolean, Column, Float, ForeignKey, Integer, MetaData, String, Table, Text, create_engine,
                        delete, event, func, insert, select, update)
from sqlalchemy.exc import IntegrityError

from scdp.errors import ScdpError

DATABASE_FILE = "responses.sqlite"
SEQ_RETRIES = 5  # a lab server's concurrent arrivals may race for the same arrival number

metadata = MetaData()
participants = Table(
    "participants", metadata,
    Column("pid", String(64), primary_key=True),
    Column("number", Integer, unique=True, nullable=False),  # arrival order, 0-based: the Latin-square row and the draws
    Column("created", Float, nullable=False),
    Column("consented", Float),
    Column("completed", Float),
)
responses = Table(
    "responses", metadata,
    Column("pid", String(64), ForeignKey("participants.pid", ondelete="CASCADE"), primary_key=True),
    Column("trial", Integer, primary_key=True),
    Column("stimulus", String(128), nullable=False),
    Column("kind", String(16), nullable=False),
    Column("mirror", Boolean, nullable=False),
    Column("colours", Text, nullable=False),  # JSON: the palette index of each goal
    Column("choice", Integer, nullable=False),
    Column("correct", Boolean, nullable=False),
    Column("events", Text, nullable=False),  # JSON: [{"t", "goal"}]
    Column("rate", Float, nullable=False),  # playback rate of the page (1 for people)
    Column("received", Float, nullable=False),
)


def database_url(folder, url: str | None = None) -> str:
    """``url`` (any SQLAlchemy URL, e.g. ``postgresql+psycopg://...``), or the study folder's SQLite file."""
    return url or f"sqlite:///{Path(folder).resolve() / DATABASE_FILE}"


class Store:
    """The responses of one study, in the database at ``url``."""

    def __init__(self, url: str):
        try:
            self.engine = create_engine(url)
        except Exception as exc:  # noqa: BLE001 - SQLAlchemy raises several kinds for a bad URL or a missing driver
            raise ScdpError("--database", f"cannot use {url!r} ({exc})") from None
        if self.engine.dialect.name == "sqlite":
            event.listen(self.engine, "connect", _sqlite_pragmas)
        metadata.create_all(self.engine)

    def participant(self, pid: str) -> dict | None:
        with self.engine.connect() as c:
            row = c.execute(select(participants).where(participants.c.pid == pid)).mappings().first()
        return dict(row) if row else None

    def arrive(self, pid: str) -> dict:
        """The participant ``pid``, registered with the next arrival number if new."""
        for _ in range(SEQ_RETRIES):
            known = self.participant(pid)
            if known:
                return known
            try:
                with self.engine.begin() as c:
                    number = c.execute(select(func.coalesce(func.max(participants.c.number) + 1, 0))).scalar_one()
                    c.execute(insert(participants).values(pid=pid, number=number, created=time.time()))
            except IntegrityError:
                continue  # another request registered pid, or took the number: look again
        known = self.participant(pid)
        if not known:
            raise ScdpError("database", "could not register the participant (too many concurrent arrivals)")
        return known

    def consent(self, pid: str) -> None:
        with self.engine.begin() as c:
            c.execute(update(participants).where(participants.c.pid == pid, participants.c.consented.is_(None))
                      .values(consented=time.time()))

    def answered(self, pid: str) -> int:
        """How many trials ``pid`` has confirmed."""
        with self.engine.connect() as c:
            return c.execute(select(func.count()).select_from(responses).where(responses.c.pid == pid)).scalar_one()

    def record(self, pid: str, trial: int, *, stimulus: str, kind: str, mirror: bool, colours: list, choice: int,
               correct: bool, events: list, rate: float, last: bool) -> bool:
        """Store one confirmed trial (and mark ``pid`` finished when it is the ``last``); False, with
        nothing changed, when that trial was already stored."""
        try:
            with self.engine.begin() as c:
                c.execute(insert(responses).values(pid=pid, trial=trial, stimulus=stimulus, kind=kind, mirror=mirror,
                                                   colours=json.dumps(colours), choice=choice, correct=correct,
                                                   events=json.dumps(events), rate=rate, received=time.time()))
                if last:
                    c.execute(update(participants).where(participants.c.pid == pid).values(completed=time.time()))
        except IntegrityError:
            return False
        return True

    def rows(self) -> list[dict]:
        """Every response joined with its participant, in arrival and trial order."""
        query = (select(responses, participants.c.number, participants.c.completed.label("participant_completed"))
                 .join(participants, participants.c.pid == responses.c.pid)
                 .order_by(participants.c.number, responses.c.trial))
        with self.engine.connect() as c:
            out = [dict(r) for r in c.execute(query).mappings()]
        for r in out:
            r["colours"], r["events"] = json.loads(r["colours"]), json.loads(r["events"])
        return out

    def delete(self, pid: str) -> int:
        """Remove ``pid`` and every response of theirs; returns how many responses went."""
        with self.engine.begin() as c:
            n = c.execute(delete(responses).where(responses.c.pid == pid)).rowcount
            gone = c.execute(delete(participants).where(participants.c.pid == pid)).rowcount
        if not gone:
            raise ScdpError("--participant", f"no participant {pid!r} in this study's database")
        return n


def _sqlite_pragmas(connection, _record) -> None:
    cursor = connection.cursor()
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.execute("PRAGMA synchronous=FULL")
    cursor.close()
