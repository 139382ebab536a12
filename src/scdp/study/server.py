"""The study's rules, over its store, on the server's clock: who may see and answer what, and when.

A trial's life, as the page lives it (:mod:`scdp.study.app` maps each step to a route)::

    state    the trial's goals and colours (never its path or target); counts a load of it
    motion   the first call starts the motion; every call returns the path (and frames) up to
             the server's clock plus LOOKAHEAD_S, never beyond: a reload resumes, never restarts
    pick     a goal clicked; the server stamps the fraction of the motion its clock has reached
    confirm  refused until the motion has played to its end; the last pick is the answer

Every route after consent needs the session token issued at consent (the page's cookie): an ID
alone answers for no one. Times come from ``clock`` (seconds), the wall clock unless a caller
drives its own (:mod:`scdp.study.participant` runs simulated participants on the page's fake clock).
"""

from __future__ import annotations

import secrets
import time

from scdp.errors import ScdpError
from scdp.study.design import LOOKAHEAD_S, assignment, motion, served_trial
from scdp.study.record import Study
from scdp.study.store import Store, token_hash

END_TOLERANCE_S = 0.05  # a Confirm this close to the motion's end counts as after it (clock granularity)


class Refused(Exception):
    """A request the study turns away with an HTTP status other than 422 (403: no session; 409: a
    trial already confirmed); ``field`` and ``message`` make the one-line error."""

    def __init__(self, status: int, field: str, message: str):
        super().__init__(message)
        self.status, self.field, self.message = status, field, message


class StudyServer:
    """The study's state machine over the store."""

    def __init__(self, study: Study, store: Store, clock=time.time):
        self.study, self.store, self.clock = study, store, clock
        self.config = study.config

    # ----- who -----
    def _person(self, pid: str, token: str | None) -> dict:
        person = self.store.participant(pid)
        if person is None:
            raise ScdpError("consent", f"{pid} has not given consent")
        if not token or not secrets.compare_digest(token_hash(token), person["token_sha256"]):
            raise Refused(403, "session", f"this browser holds no session of {pid}: open the study from the link "
                                          "you were given, in the browser you started it in")
        return person

    def _current(self, person: dict, trial: int) -> tuple[list, int]:
        trials = assignment(self.study, person["number"], person["row"])
        answered = self.store.answered(person["pid"])
        if trial < answered:
            raise Refused(409, "trial", f"trial {trial} of {person['pid']} is already confirmed")
        if trial >= len(trials):
            raise ScdpError("trial", f"{person['pid']} was assigned trials 0 to {len(trials) - 1}, got {trial}")
        if trial > answered:
            raise ScdpError("trial", f"{person['pid']} is at trial {answered}, got {trial}")
        return trials, answered

    def _elapsed(self, pid: str, trial: int) -> float:
        record = self.store.served(pid, trial)
        if record is None or record["played"] is None:
            raise ScdpError("trial", f"the motion of trial {trial} has not started (press Start)")
        return self.clock() - record["played"]

    # ----- routes -----
    def state(self, pid: str, token: str | None) -> dict:
        """Where ``pid`` is: consent (nothing stored for an ID that has not consented), a trial, or done."""
        person = self.store.participant(pid)
        if person is None:
            return {"pid": pid, "screen": "consent", "task": self.study.task}
        person = self._person(pid, token)
        trials = assignment(self.study, person["number"], person["row"])
        answered = self.store.answered(pid)
        out = {"pid": pid, "n_trials": len(trials), "answered": answered, "task": self.study.task}
        if answered >= len(trials):
            code = self.config.completion_code
            return {**out, "screen": "done", "code": code,
                    "redirect": self.config.completion_url.replace("{code}", code)}
        trial = trials[answered]
        record = self.store.serve(pid, trial.index, self.clock())
        positions = [p["position"] for p in self.store.picks(pid, trial.index)]
        return {**out, "screen": "trial", "trial": served_trial(self.study, trial, len(trials)),
                "playing": record["played"] is not None, "picked": positions[-1] if positions else None}

    def consent(self, pid: str, token: str | None) -> tuple[dict, str | None]:
        """Record consent; the state and a new session token (None when this browser already has one)."""
        if self.store.participant(pid) is not None:
            return self.state(pid, token), None  # refused unless this browser holds pid's session
        _, new = self.store.register(pid, self.clock(), rows=len(self.config.methods),
                                     timeout_s=60.0 * self.config.slot_timeout_min)
        return self.state(pid, new), new

    def motion(self, pid: str, token: str | None, trial: int) -> dict:
        person = self._person(pid, token)
        trials, _ = self._current(person, trial)
        played = self.store.play(pid, trial, self.clock())
        elapsed = self.clock() - played
        duration = self.config.duration_s
        upto = min(1.0, (elapsed + LOOKAHEAD_S) / duration)
        return {"trial": trial, "elapsed": min(1.0, elapsed / duration), **motion(self.study, trials[trial], upto)}

    def pick(self, pid: str, token: str | None, trial: int, position: int, t: float) -> dict:
        person = self._person(pid, token)
        trials, _ = self._current(person, trial)
        goals = trials[trial].order
        if position >= len(goals):
            raise ScdpError("goal", f"trial {trial} has goals 0 to {len(goals) - 1}, got {position}")
        elapsed = self._elapsed(pid, trial)
        duration = self.config.duration_s
        allowed = min(1.0, (elapsed + LOOKAHEAD_S) / duration)
        if t > allowed + 1e-6:
            raise ScdpError("t", f"{t:.3f} of the motion had not been served yet ({allowed:.3f} had)")
        self.store.pick(pid, trial, position=position, goal=goals[position], client_t=t,
                        server_t=min(1.0, elapsed / duration), now=self.clock())
        return {"trial": trial, "picked": position}

    def confirm(self, pid: str, token: str | None, trial: int) -> dict:
        person = self._person(pid, token)
        trials, _ = self._current(person, trial)
        duration = self.config.duration_s
        elapsed = self._elapsed(pid, trial)
        if elapsed < duration - END_TOLERANCE_S:
            raise ScdpError("trial", f"the motion of trial {trial} is still playing ({elapsed:.1f} s of {duration:g} s)")
        chosen = self.store.picks(pid, trial)
        if not chosen:
            raise ScdpError("choice", f"no goal picked in trial {trial}")
        spec, record = trials[trial], self.store.served(pid, trial)
        stim = self.study.stimuli[spec.stimulus]
        events = [{"t": round(p["server_t"], 4), "client_t": round(p["client_t"], 4), "goal": p["goal"]} for p in chosen]
        stored = self.store.record(pid, trial, now=self.clock(), last=trial == len(trials) - 1,
                                   stimulus=spec.stimulus, kind=spec.kind, mirror=spec.mirror, colours=spec.colours,
                                   goal_order=spec.order, choice=chosen[-1]["goal"],
                                   correct=chosen[-1]["goal"] == stim.target, events=events,
                                   served=record["first"], played=record["played"], loads=record["loads"],
                                   replays=record["replays"])
        if not stored:  # a concurrent duplicate got there first
            raise Refused(409, "trial", f"trial {trial} of {pid} is already confirmed")
        return self.state(pid, token)
