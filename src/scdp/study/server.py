"""The study's rules, over its store, on the server's clock: who may see and answer what, and when.

A participant's life, as the page lives it (:mod:`scdp.study.app` maps each step to a route)::

    consent       records consent (with the platform's study and session IDs), issues the session;
                  or decline: nothing stored, the declined code
    comprehend    the comprehension check after the instructions; failed comprehension_attempts times: screened out
    state         the trial's goals and colours (never its path or target); counts a load of it
    motion        the first call starts the motion; every call returns the path (and frames) up to
                  the server's clock plus lookahead_s, never beyond: a reload resumes, never restarts
    pick          a goal clicked (the page says how many seconds of the motion it showed); the server
                  stamps the fraction of the motion its clock has reached, and its seconds;
                  at most ``max_picks`` a trial, pick_interval_s apart (refusals are counted)
    focus         the page was hidden or lost focus while a motion played (counted)
    confirm       refused until the motion has played to its end; the last pick is the answer, with
                  the participant's confidence; the practice's answer says whether it was right
    rate          the end-of-study ratings (one motion per method); then done, the code and the debrief

Every route after consent needs the session token issued at consent (the page's cookie): an ID
alone answers for no one. A session ends with the slot: ``slot_timeout_min`` after consent an
unfinished participant's session is refused (410), so a row given to someone else is never
finished twice. Times come from ``clock`` (seconds), the wall clock unless a caller drives its own
(:mod:`scdp.study.participant` runs simulated participants on the page's fake clock).
"""

from __future__ import annotations

import secrets
import time
from functools import lru_cache

from scdp.errors import ScdpError
from scdp.study import questions
from scdp.study.design import PALETTE, assignment, motion, rating_items, served_trial
from scdp.study.record import INSTRUCTED, PRACTICE, Study
from scdp.study.response import Response
from scdp.study.store import Store, token_hash

PICK_RESOLUTION_S = 1e-3  # the page sends a pick's time in whole milliseconds (rounded down; an older page rounded)


class Refused(Exception):
    """A request the study turns away with an HTTP status other than 422 (403: no session; 409: a
    trial already confirmed; 410: the slot expired; 429: a pick over the cap or too fast); ``field``
    and ``message`` make the one-line error."""

    def __init__(self, status: int, field: str, message: str):
        super().__init__(message)
        self.status, self.field, self.message = status, field, message


ASSIGNMENTS_KEPT = 4096  # participants whose trials the server keeps drawn (a few kB each)


class StudyServer:
    """The study's state machine over the store."""

    def __init__(self, study: Study, store: Store, clock=time.time):
        self.study, self.store, self.clock = study, store, clock
        self.config = study.config
        # a participant's trials, drawn once (the draw depends on the consent number and row alone)
        self.trials_of = lru_cache(maxsize=ASSIGNMENTS_KEPT)(lambda number, row: assignment(study, number, row))

    # ----- who -----
    def _person(self, pid: str, token: str | None) -> dict:
        person = self.store.participant(pid)
        if person is None:
            raise ScdpError("consent", f"{pid} has not given consent")
        if not token or not secrets.compare_digest(token_hash(token), person["token_sha256"]):
            raise Refused(403, "session", f"this browser holds no session of {pid}: open the study from the link "
                                          "you were given, in the browser you started it in")
        ended = person["completed"] is not None or person["screened_out"] is not None
        if not ended and self.clock() - person["consented"] > 60.0 * self.config.slot_timeout_min:
            raise Refused(410, "session", f"the time for this study ran out ({self.config.slot_timeout_min:g} min "
                                          "after consent), so your place went to another participant; please return "
                                          "to the study platform")
        return person

    def _current(self, person: dict, trial: int) -> tuple[list, int]:
        if person["comprehended"] is None:
            raise ScdpError("trial", f"{person['pid']} has not passed the comprehension check")
        trials = self.trials_of(person["number"], person["row"])
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

    def _end(self, screen: str, code: str, out: dict) -> dict:
        return {**out, "screen": screen, "code": code, "redirect": self.config.completion_url.replace("{code}", code)}

    # ----- routes -----
    def state(self, pid: str, token: str | None) -> dict:
        """Where ``pid`` is: consent (nothing stored for an ID that has not consented), the instructions
        and comprehension check, a trial, the ratings, or an end (done, screened out)."""
        person = self.store.participant(pid)
        if person is None:
            return {"pid": pid, "screen": "consent", "task": self.study.task}
        person = self._person(pid, token)
        trials = self.trials_of(person["number"], person["row"])
        answered = self.store.answered(pid)
        out = {"pid": pid, "n_trials": len(trials), "answered": answered, "task": self.study.task}
        if person["screened_out"] is not None:
            return self._end("screened", self.config.screened_code, out)
        if person["comprehended"] is None:
            return {**out, "screen": "instructions", "questions": questions.questions(),
                    "attempts_left": self.config.comprehension_attempts - person["comprehension_failures"]}
        if person["completed"] is not None:
            return {**self._end("done", self.config.completion_code, out), "debrief": True}
        if answered >= len(trials):
            items = [{"item": i, "trial": served_trial(self.study, trials[i], len(trials)),
                      "motion": motion(self.study, trials[i], self.study.motion_s(trials[i].stimulus))}
                     for i in rating_items(self.study, trials, person["number"])]
            return {**out, "screen": "ratings", "items": items, "scale": questions.SCALE,
                    "statements": questions.RATINGS}
        trial = trials[answered]
        record = self.store.serve(pid, trial.index, self.clock())
        positions = [p["position"] for p in self.store.picks(pid, trial.index)]
        return {**out, "screen": "trial", "trial": served_trial(self.study, trial, len(trials)),
                "playing": record["played"] is not None, "picked": positions[-1] if positions else None,
                "confidence": list(questions.CONFIDENCE)}

    def consent(self, pid: str, token: str | None, platform: tuple[str, str] = ("", "")) -> tuple[dict, str | None]:
        """Record consent; the state and a new session token (None when this browser already has one)."""
        if self.store.participant(pid) is not None:
            return self.state(pid, token), None  # refused unless this browser holds pid's session
        _, new = self.store.register(pid, self.clock(), rows=len(self.config.methods),
                                     timeout_s=60.0 * self.config.slot_timeout_min, platform=platform)
        return self.state(pid, new), new

    def decline(self, pid: str) -> dict:
        """``pid`` does not agree: nothing is stored; the declined code (and the platform's redirect)."""
        if self.store.participant(pid) is not None:
            raise Refused(409, "consent", f"{pid} has already consented; to withdraw, contact the researcher, who "
                                          "deletes every answer (scdp study delete)")
        return self._end("declined", self.config.declined_code, {"pid": pid})

    def comprehend(self, pid: str, token: str | None, answers: list[int]) -> dict:
        """Score the comprehension check; the state after it (a trial, the instructions again, or screened out)."""
        person = self._person(pid, token)
        if person["comprehended"] is None and person["screened_out"] is None:
            if len(answers) != len(questions.COMPREHENSION):
                raise ScdpError("answers", f"needs one answer to each of the {len(questions.COMPREHENSION)} "
                                           f"questions, got {len(answers)}")
            self.store.comprehension(pid, questions.comprehension_passed(answers), self.clock(), self.config.comprehension_attempts)
        return self.state(pid, token)

    def motion(self, pid: str, token: str | None, trial: int) -> dict:
        person = self._person(pid, token)
        trials, _ = self._current(person, trial)
        played = self.store.play(pid, trial, self.clock())
        return {"trial": trial, **motion(self.study, trials[trial], self.clock() - played)}

    def pick(self, pid: str, token: str | None, trial: int, position: int, t: float) -> dict:
        """A goal clicked when the page showed ``t`` seconds of the motion; stored as fractions of the
        motion, the server's clock's and the page's."""
        person = self._person(pid, token)
        trials, _ = self._current(person, trial)
        goals = trials[trial].order
        if position >= len(goals):
            raise ScdpError("goal", f"trial {trial} has goals 0 to {len(goals) - 1}, got {position}")
        elapsed = self._elapsed(pid, trial)
        duration = self.study.motion_s(trials[trial].stimulus)
        allowed = min(duration, elapsed + self.config.lookahead_s)
        if t > allowed + PICK_RESOLUTION_S:  # within the page's resolution of what was served, it is what was served
            raise ScdpError("t", f"{t:.3f} s of the motion had not been served yet ({allowed:.3f} s had)")
        t = min(t, allowed)
        before = self.store.picks(pid, trial)
        if len(before) >= self.config.max_picks or (before and self.clock() - before[-1]["at"] < self.config.pick_interval_s):
            self.store.count(pid, trial, "refused")
            why = (f"at most {self.config.max_picks} picks a trial" if len(before) >= self.config.max_picks else
                   f"picks at least {self.config.pick_interval_s:g} s apart")
            raise Refused(429, "goal", f"pick not recorded: {why}; your last pick stands")
        self.store.pick(pid, trial, position=position, goal=goals[position], client_t=min(1.0, t / duration),
                        server_t=min(1.0, elapsed / duration), now=self.clock())
        return {"trial": trial, "picked": position}

    def focus(self, pid: str, token: str | None, trial: int, event: str) -> dict:
        """Count the page being hidden or losing focus while ``trial``'s motion plays (before Confirm)."""
        person = self._person(pid, token)
        self._current(person, trial)
        record = self.store.served(pid, trial)
        counted = record is not None and record["played"] is not None
        if counted:
            self.store.count(pid, trial, "hidden" if event == "hidden" else "blurs")
        return {"trial": trial, "counted": counted}

    def confirm(self, pid: str, token: str | None, trial: int, confidence: int) -> dict:
        person = self._person(pid, token)
        trials, _ = self._current(person, trial)
        duration = self.study.motion_s(trials[trial].stimulus)
        elapsed = self._elapsed(pid, trial)
        if elapsed < duration - self.config.end_tolerance_s:
            raise ScdpError("trial", f"the motion of trial {trial} is still playing")  # never how long it has left
        chosen = self.store.picks(pid, trial)
        if not chosen:
            raise ScdpError("choice", f"no goal picked in trial {trial}")
        spec, record = trials[trial], self.store.served(pid, trial)
        stim = self.study.stimuli[spec.stimulus]
        target_position, choice = spec.order.index(stim.target), chosen[-1]
        correct = (choice["position"] == spec.instructed if spec.kind == INSTRUCTED else choice["goal"] == stim.target)
        events = [{"t": round(p["server_t"], 4), "client_t": round(p["client_t"], 4), "s": round(p["server_t"] * duration, 3),
                   "goal": p["goal"]} for p in chosen]  # fractions of the motion, and the server's seconds
        stored = self.store.record(Response(
            pid=pid, trial=trial, stimulus=spec.stimulus, kind=spec.kind, mirror=spec.mirror, colours=list(spec.colours),
            goal_order=list(spec.order), choice=choice["goal"], correct=bool(correct), events=events,
            served=record["first"], played=record["played"], confirmed=self.clock(), loads=record["loads"],
            replays=record["replays"], target_position=target_position, choice_position=choice["position"],
            instructed=spec.instructed, confidence=confidence, hidden=record["hidden"], blurs=record["blurs"],
            refused=record["refused"]))
        if not stored:  # a concurrent duplicate got there first
            raise Refused(409, "trial", f"trial {trial} of {pid} is already confirmed")
        out = self.state(pid, token)
        if spec.kind == PRACTICE:  # feedback on the practice only: the main trials' targets stay the server's
            out["feedback"] = {"correct": bool(correct), "colour": PALETTE[spec.colours[target_position]][0]}
        return out

    def rate(self, pid: str, token: str | None, given: list[dict]) -> dict:
        """Store the end-of-study ratings ({"item", "legible", "predictable"} per rated trial); the end."""
        person = self._person(pid, token)
        trials = self.trials_of(person["number"], person["row"])
        if self.store.answered(pid) < len(trials) or person["comprehended"] is None:
            raise ScdpError("ratings", f"{pid} has trials left to answer")
        items = rating_items(self.study, trials, person["number"])
        if sorted(g["item"] for g in given) != sorted(items):
            raise ScdpError("ratings", f"must rate exactly the trials {sorted(items)}, got {sorted(g['item'] for g in given)}")
        rows = [{"trial": g["item"], "stimulus": trials[g["item"]].stimulus, "legible": g["legible"],
                 "predictable": g["predictable"], "method": self.study.stimuli[trials[g["item"]].stimulus].method}
                for g in given]
        if not self.store.rate(pid, rows, self.clock()):
            raise Refused(409, "ratings", f"{pid} has already given their ratings")
        return self.state(pid, token)
