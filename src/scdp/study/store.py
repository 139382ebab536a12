"""Where a study's responses live: a SQL database through SQLAlchemy (SQLite by default).

Five tables, every time in seconds of the server's clock:

* ``participants``: one row per ID that *consented* (an ID that only opened the link, or declined,
  leaves no trace): their consent number (which decides their draws), their Latin-square row, the
  platform's study and session IDs, when they consented, passed the comprehension check (or were
  screened out by it) and finished, and the SHA-256 of their session token (the cookie the page
  holds; the token itself is never stored).
* ``served``: per (participant, trial), when it was first served, how often the page loaded it,
  when its motion started playing, how many loads came while it played (replays), how often the
  page was hidden or lost focus while it played, and how many picks were refused (cap, rate).
* ``picks``: every goal a participant clicked, in order, with the fraction of the motion the
  page showed (``client_t``) and the fraction the server's clock had reached (``server_t``).
* ``responses``: one row per confirmed trial, keyed by (participant, trial), with its confidence.
* ``ratings``: the end-of-study ratings, one row per rated trial.

Every write is one transaction, committed before the server answers, so a confirmed response
survives the server being killed at any later moment; SQLite runs with its default full
synchronisation. A second response to the same trial violates the primary key and is refused;
nothing stored changes. What is stored about a person is the ID the recruiting platform passed,
their answers and their times, nothing else (no IP address, no browser details):
:meth:`Store.delete` removes a participant entirely.
"""

from __future__ import annotations

import hashlib
import json
import secrets
from pathlib import Path

from sqlalchemy import (
    Column,
    Float,
    ForeignKey,
    Integer,
    MetaData,
    String,
    Table,
    and_,
    create_engine,
    delete,
    event,
    func,
    insert,
    or_,
    select,
    update,
)
from sqlalchemy.exc import IntegrityError

from scdp.errors import ScdpError
from scdp.study.response import JSON_FIELDS, Response, response_columns

DATABASE_FILE = "responses.sqlite"
SIMULATED_FILE = "simulated.sqlite"  # scdp study simulate's own database, apart from people's
RETRIES = 5  # a lab server's concurrent consents may race for the same consent number

metadata = MetaData()
participants = Table(
    "participants", metadata,
    Column("pid", String(64), primary_key=True),
    Column("number", Integer, unique=True, nullable=False),  # consent order, 0-based: the participant's draws
    Column("row", Integer, nullable=False),  # the Latin-square row
    Column("consented", Float, nullable=False),
    Column("completed", Float),  # rated the motions at the end: finished
    Column("token_sha256", String(64), nullable=False),
    Column("platform_study", String(64), nullable=False, default=""),  # e.g. Prolific's STUDY_ID
    Column("platform_session", String(64), nullable=False, default=""),  # e.g. Prolific's SESSION_ID
    Column("comprehended", Float),  # passed the comprehension check
    Column("comprehension_failures", Integer, nullable=False, default=0),
    Column("screened_out", Float),  # failed the comprehension check too often: ended with the screened-out code
)
served = Table(
    "served", metadata,
    Column("pid", String(64), ForeignKey("participants.pid", ondelete="CASCADE"), primary_key=True),
    Column("trial", Integer, primary_key=True),
    Column("first", Float, nullable=False),  # first served
    Column("loads", Integer, nullable=False),  # how often the page received it
    Column("played", Float),  # when its motion started
    Column("replays", Integer, nullable=False),  # loads while (or after) the motion played
    Column("hidden", Integer, nullable=False, default=0),  # the page was hidden (tab switched) while it played
    Column("blurs", Integer, nullable=False, default=0),  # the window lost focus while it played
    Column("refused", Integer, nullable=False, default=0),  # picks refused: over the cap or too fast
)
picks = Table(
    "picks", metadata,
    Column("pid", String(64), ForeignKey("participants.pid", ondelete="CASCADE"), primary_key=True),
    Column("trial", Integer, primary_key=True),
    Column("seq", Integer, primary_key=True),
    Column("position", Integer, nullable=False),  # the button (served position) clicked
    Column("goal", Integer, nullable=False),  # the stimulus's goal at that position
    Column("client_t", Float, nullable=False),
    Column("server_t", Float, nullable=False),
    Column("at", Float, nullable=False),
)
responses = Table(
    "responses", metadata, *response_columns(),
)
ratings = Table(
    "ratings", metadata,
    Column("pid", String(64), ForeignKey("participants.pid", ondelete="CASCADE"), primary_key=True),
    Column("trial", Integer, primary_key=True),  # the rated trial (one per method the participant saw)
    Column("stimulus", String(128), nullable=False),
    Column("method", String(32), nullable=False),
    Column("legible", Integer, nullable=False),  # 1..7: the goal was clear early
    Column("predictable", Integer, nullable=False),  # 1..7: the motion was what I expected
    Column("at", Float, nullable=False),
)


def database_url(folder, url: str | None = None, file: str = DATABASE_FILE) -> str:
    """``url`` (any SQLAlchemy URL, e.g. ``postgresql+psycopg://...``), or the study folder's SQLite ``file``."""
    return url or f"sqlite:///{Path(folder).resolve() / file}"


def token_hash(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


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

    # ----- participants -----
    def participant(self, pid: str) -> dict | None:
        with self.engine.connect() as c:
            row = c.execute(select(participants).where(participants.c.pid == pid)).mappings().first()
        return dict(row) if row else None

    def participants(self) -> list[dict]:
        """Every participant who consented, in consent order."""
        with self.engine.connect() as c:
            return [dict(r) for r in c.execute(select(participants).order_by(participants.c.number)).mappings()]

    def register(self, pid: str, now: float, rows: int, timeout_s: float,
                 platform: tuple[str, str] = ("", "")) -> tuple[dict, str]:
        """Record ``pid``'s consent: the next consent number, the Latin-square row (of ``rows``) with the
        fewest finished or active participants (active: consented within ``timeout_s``, not finished,
        not screened out; ties to the lowest row), the ``platform``'s (study, session) IDs and a new
        session token, returned with the participant."""
        token = secrets.token_urlsafe(24)
        for _ in range(RETRIES):
            try:
                with self.engine.begin() as c:
                    number = c.execute(select(func.coalesce(func.max(participants.c.number) + 1, 0))).scalar_one()
                    taken = c.execute(select(participants.c.row, func.count()).where(or_(
                        participants.c.completed.is_not(None), and_(participants.c.consented > now - timeout_s,
                                                                    participants.c.screened_out.is_(None))))
                        .group_by(participants.c.row)).all()
                    counts = dict.fromkeys(range(rows), 0) | {int(r): int(n) for r, n in taken if r < rows}
                    row = min(counts, key=lambda r: (counts[r], r))
                    c.execute(insert(participants).values(pid=pid, number=number, row=row, consented=now,
                                                          token_sha256=token_hash(token), platform_study=platform[0],
                                                          platform_session=platform[1]))
                return self.participant(pid), token
            except IntegrityError:
                if self.participant(pid):
                    raise ScdpError("pid", f"{pid} has already started this study") from None
        raise ScdpError("database", "could not register the participant (too many concurrent consents)")

    def comprehension(self, pid: str, passed: bool, now: float, attempts: int) -> dict:
        """Record one answer to the comprehension check: passed, or one more failure (screened out at
        ``attempts`` failures); the participant's row after it."""
        with self.engine.begin() as c:
            if passed:
                c.execute(update(participants).where(participants.c.pid == pid).values(comprehended=now))
            else:
                c.execute(update(participants).where(participants.c.pid == pid)
                          .values(comprehension_failures=participants.c.comprehension_failures + 1))
                c.execute(update(participants).where(participants.c.pid == pid,
                                                     participants.c.comprehension_failures >= attempts)
                          .values(screened_out=now))
        return self.participant(pid)

    # ----- a trial's life: served, played, picked, confirmed -----
    def serve(self, pid: str, trial: int, now: float) -> dict:
        """Count one load of ``trial`` (a replay when its motion already started); its served row."""
        with self.engine.begin() as c:
            known = c.execute(select(served).where(served.c.pid == pid, served.c.trial == trial)).mappings().first()
            if known is None:
                c.execute(insert(served).values(pid=pid, trial=trial, first=now, loads=1, played=None, replays=0))
            else:
                replay = int(known["played"] is not None)
                c.execute(update(served).where(served.c.pid == pid, served.c.trial == trial)
                          .values(loads=served.c.loads + 1, replays=served.c.replays + replay))
        return self.served(pid, trial)

    def served(self, pid: str, trial: int) -> dict | None:
        with self.engine.connect() as c:
            row = c.execute(select(served).where(served.c.pid == pid, served.c.trial == trial)).mappings().first()
        return dict(row) if row else None

    def play(self, pid: str, trial: int, now: float) -> float:
        """When ``trial``'s motion started: now, unless it already had (a reload resumes, never restarts)."""
        with self.engine.begin() as c:
            c.execute(update(served).where(served.c.pid == pid, served.c.trial == trial, served.c.played.is_(None))
                      .values(played=now))
        return self.served(pid, trial)["played"]

    def count(self, pid: str, trial: int, what: str) -> None:
        """One more of ``what`` ("hidden", "blurs" or "refused") in ``trial``'s served row."""
        column = served.c[what]
        with self.engine.begin() as c:
            c.execute(update(served).where(served.c.pid == pid, served.c.trial == trial).values({column: column + 1}))

    def pick(self, pid: str, trial: int, *, position: int, goal: int, client_t: float, server_t: float,
             now: float) -> None:
        for _ in range(RETRIES):
            try:
                with self.engine.begin() as c:
                    seq = c.execute(select(func.count()).select_from(picks).where(
                        and_(picks.c.pid == pid, picks.c.trial == trial))).scalar_one()
                    c.execute(insert(picks).values(pid=pid, trial=trial, seq=seq, position=position, goal=goal,
                                                   client_t=client_t, server_t=server_t, at=now))
                return
            except IntegrityError:
                continue  # a concurrent pick took this sequence number
        raise ScdpError("database", "could not record the pick (too many concurrent picks)")

    def picks(self, pid: str, trial: int) -> list[dict]:
        with self.engine.connect() as c:
            return [dict(r) for r in c.execute(select(picks).where(picks.c.pid == pid, picks.c.trial == trial)
                                               .order_by(picks.c.seq)).mappings()]

    def answered(self, pid: str) -> int:
        """How many trials ``pid`` has confirmed."""
        with self.engine.connect() as c:
            return c.execute(select(func.count()).select_from(responses).where(responses.c.pid == pid)).scalar_one()

    def record(self, response: Response) -> bool:
        """Store one confirmed trial; False, with nothing changed, when that trial was already stored."""
        try:
            with self.engine.begin() as c:
                c.execute(insert(responses).values(**response.row()))
        except IntegrityError:
            return False
        return True

    def rate(self, pid: str, items: list[dict], now: float) -> bool:
        """Store the end-of-study ratings (dicts of trial, stimulus, method, legible, predictable) and
        mark ``pid`` finished; False, with nothing changed, when they were already stored."""
        try:
            with self.engine.begin() as c:
                if items:  # a run without main trials has nothing to rate
                    c.execute(insert(ratings), [{"pid": pid, "at": now, **item} for item in items])
                c.execute(update(participants).where(participants.c.pid == pid).values(completed=now))
        except IntegrityError:
            return False
        return True

    def ratings(self) -> list[dict]:
        """Every rating, in consent and trial order."""
        query = (select(ratings).join(participants, participants.c.pid == ratings.c.pid)
                 .order_by(participants.c.number, ratings.c.trial))
        with self.engine.connect() as c:
            return [dict(r) for r in c.execute(query).mappings()]

    def rows(self) -> list[dict]:
        """Every response joined with its participant, in consent and trial order."""
        query = (select(responses, participants.c.number, participants.c.row,
                        participants.c.consented.label("participant_consented"),
                        participants.c.completed.label("participant_completed"))
                 .join(participants, participants.c.pid == responses.c.pid)
                 .order_by(participants.c.number, responses.c.trial))
        with self.engine.connect() as c:
            out = [dict(r) for r in c.execute(query).mappings()]
        for r in out:
            for key in JSON_FIELDS:
                r[key] = json.loads(r[key])
        return out

    def delete(self, pid: str) -> int:
        """Remove ``pid`` and everything of theirs; returns how many responses went."""
        with self.engine.begin() as c:
            n = c.execute(delete(responses).where(responses.c.pid == pid)).rowcount
            for table in (picks, served, ratings):
                c.execute(delete(table).where(table.c.pid == pid))
            gone = c.execute(delete(participants).where(participants.c.pid == pid)).rowcount
        if not gone:
            raise ScdpError("--participant", f"no participant {pid!r} in this study's database")
        return n


def _sqlite_pragmas(connection, _record) -> None:
    cursor = connection.cursor()
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.execute("PRAGMA synchronous=FULL")
    cursor.close()
