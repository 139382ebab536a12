"""``scdp study serve``: the study's web app (FastAPI) over its database (:mod:`scdp.study.store`).

The page (``page.html``, one self-contained file) talks to four routes, all JSON::

    POST /api/state     {"pid"}                       -> where the participant is: consent, a trial, or done
    POST /api/consent   {"pid"}                       -> the same, after recording consent
    POST /api/response  {"pid", "trial", "events", "choice", "rate"} -> stores a confirmed trial, then the state
    GET  /stimuli/...                                  the Block Reach frames

A participant's ID arrives as the page's query parameter (``?pid=...``, as crowdsourcing platforms
pass it). The server, not the page, knows each trial's target; the page gets the motion, the
goals and their colours only. Refusals follow the project's contract, one line
``{"error": "<field>: <problem>"}``: 422 for a malformed body, a trial the participant was not
assigned (or not yet reached), a goal that does not exist, or a response before consent; 409 for
a trial already confirmed. A refused request changes nothing stored.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel, ConfigDict, Field

from scdp.errors import ScdpError
from scdp.serve.errors import error_response, install_error_handlers
from scdp.study.design import assignment, served_trial
from scdp.study.store import Store

PID_PATTERN = r"^[A-Za-z0-9_.-]{1,64}$"
CONSENT_FILE = "consent.html"  # in the study folder: the consent text your ethics board approved
DEFAULT_CONSENT = ("<p><b>Placeholder consent text.</b> The researcher running this study replaces it with the "
                   "consent form their ethics board approved, as <code>consent.html</code> in the study folder "
                   "(docs/study.md).</p><p>You will watch short animations of a robot and say which goal it is heading "
                   "to. It takes a few minutes. What is stored: the ID in your link and your answers, nothing else.</p>")
MAX_EVENTS = 500


class Conflict(Exception):
    """A second response to a confirmed trial: 409."""

    def __init__(self, field: str, message: str):
        super().__init__(message)
        self.field, self.message = field, message


class Who(BaseModel):
    model_config = ConfigDict(extra="forbid")
    pid: str = Field(pattern=PID_PATTERN, description="the participant's ID (letters, digits, _ . -; at most 64)")


class Event(BaseModel):
    model_config = ConfigDict(extra="forbid")
    t: float = Field(ge=0.0, le=1.0, allow_inf_nan=False, description="fraction of the motion shown when picked")
    goal: int = Field(ge=0, le=9, description="the goal picked, by its index in the trial's goal list")


class Answer(Who):
    trial: int = Field(ge=0, le=10_000, description="the trial's index (0 is the practice)")
    events: list[Event] = Field(min_length=1, max_length=MAX_EVENTS, description="every pick, in order")
    choice: int = Field(ge=0, le=9, description="the confirmed goal: the last pick")
    rate: float = Field(default=1.0, gt=0.0, le=100.0, allow_inf_nan=False, description="playback rate (1 for people)")


class StudyServer:
    """The study's state machine over the store: who is where, and what may be stored."""

    def __init__(self, study: dict, store: Store):
        self.study, self.store = study, store

    def _trials(self, number: int):
        return assignment(self.study, number)

    def state(self, pid: str) -> dict:
        person = self.store.arrive(pid)
        trials = self._trials(person["number"])
        answered = self.store.answered(pid)
        out = {"pid": pid, "n_trials": len(trials), "answered": answered, "task": self.study["task"]}
        if person["consented"] is None:
            return {**out, "screen": "consent"}
        if answered >= len(trials):
            return {**out, "screen": "done", "code": self.study["config"]["completion_code"]}
        return {**out, "screen": "trial", "trial": served_trial(self.study, trials[answered], len(trials))}

    def consent(self, pid: str) -> dict:
        self.store.arrive(pid)
        self.store.consent(pid)
        return self.state(pid)

    def answer(self, a: Answer) -> dict:
        person = self.store.participant(a.pid)
        if person is None:
            raise ScdpError("pid", f"{a.pid} has not started this study")
        if person["consented"] is None:
            raise ScdpError("consent", f"{a.pid} has not given consent")
        trials = self._trials(person["number"])
        answered = self.store.answered(a.pid)
        if a.trial < answered:
            raise Conflict("trial", f"trial {a.trial} of {a.pid} is already confirmed")
        if a.trial >= len(trials):
            raise ScdpError("trial", f"{a.pid} was assigned trials 0 to {len(trials) - 1}, got {a.trial}")
        if a.trial > answered:
            raise ScdpError("trial", f"{a.pid} is at trial {answered}, got {a.trial}")
        trial = trials[a.trial]
        stim = self.study["stimuli"][trial.stimulus]
        n_goals = len(stim["goals"])
        if any(e.goal >= n_goals for e in a.events) or a.choice >= n_goals:
            raise ScdpError("events", f"trial {a.trial} has goals 0 to {n_goals - 1}")
        if any(b.t < e.t for e, b in zip(a.events, a.events[1:])):
            raise ScdpError("events", "the picks' times must not decrease")
        if a.choice != a.events[-1].goal:
            raise ScdpError("choice", f"must be the last pick ({a.events[-1].goal}), got {a.choice}")
        stored = self.store.record(a.pid, a.trial, stimulus=trial.stimulus, kind=trial.kind, mirror=trial.mirror,
                                   colours=trial.colours, choice=a.choice, correct=a.choice == stim["target"],
                                   events=[e.model_dump() for e in a.events], rate=a.rate,
                                   last=a.trial == len(trials) - 1)
        if not stored:  # a concurrent duplicate got there first
            raise Conflict("trial", f"trial {a.trial} of {a.pid} is already confirmed")
        return self.state(a.pid)


def page_html() -> str:
    return resources.files("scdp.study").joinpath("page.html").read_text(encoding="utf-8")


def create_app(study: dict, folder, store: Store) -> FastAPI:
    """The study's web app: the page, its JSON routes and the stimuli's frames."""
    server = StudyServer(study, store)
    app = FastAPI(title=f"scdp study: {study['task']}", description="An online observer study of robot motion "
                                                                    "(scdp study serve --help).")
    install_error_handlers(app)
    consent_file = Path(folder) / CONSENT_FILE
    page = page_html().replace("<!--CONSENT-->", consent_file.read_text(encoding="utf-8") if consent_file.is_file()
                               else DEFAULT_CONSENT)

    @app.exception_handler(Conflict)
    async def conflict(request: Request, exc: Conflict):
        return error_response(409, exc.field, exc.message)

    @app.get("/", response_class=HTMLResponse, include_in_schema=False)
    def index() -> str:
        return page

    @app.post("/api/state")
    def state(who: Who) -> dict:
        return server.state(who.pid)

    @app.post("/api/consent")
    def consent(who: Who) -> dict:
        return server.consent(who.pid)

    @app.post("/api/response")
    def response(answer: Answer) -> dict:
        return server.answer(answer)

    stimuli = Path(folder) / "stimuli"
    if stimuli.is_dir():
        app.mount("/stimuli", StaticFiles(directory=stimuli), name="stimuli")
    return app
