"""``scdp study serve``: the study's web app (FastAPI) over its rules (:mod:`scdp.study.server`).

The page (``page.html`` with ``page_draw.js`` and ``page.js`` inlined: one self-contained document) talks to these JSON routes::

    POST /api/state          {"pid"}                         -> where the participant is (a screen)
    POST /api/consent        {"pid", "study_id", "session_id"} -> records consent; sets the session cookie
    POST /api/decline        {"pid"}                         -> the declined code; nothing stored
    POST /api/comprehension  {"pid", "answers"}              -> the first trial, the instructions again, or screened out
    POST /api/motion         {"pid", "trial"}                -> the motion so far (the first call starts it)
    POST /api/pick           {"pid", "trial", "goal", "t"}   -> a goal clicked, t seconds into the motion shown
    POST /api/focus          {"pid", "trial", "event"}       -> the page was hidden or lost focus (counted)
    POST /api/response       {"pid", "trial", "confidence"}  -> confirms the last pick, then the state
    POST /api/ratings        {"pid", "ratings"}              -> the end-of-study ratings, then the code and debrief
    GET  /frames/<name>.jpg                                    Block Reach frames (opaque names, revealed by /api/motion)

A participant's ID arrives as the page's query parameter (``?pid=...`` or Prolific's
``PROLIFIC_PID``, with ``STUDY_ID`` and ``SESSION_ID``, which are stored); consent issues a session
token, kept by the browser as an HTTP-only cookie named after the ID (so several IDs in one browser
each keep theirs), that every later route requires (403 without it). The server, not the page,
knows each trial's target, and the page receives the path only as fast as the motion plays.
Refusals follow the project's contract, one line ``{"error": "<field>: <problem>"}``: 422 for a
malformed body, a trial not reached, a goal that does not exist, a Confirm before the motion
ended; 403 without the session; 409 for a trial already confirmed; 410 past the slot's time; 429
for a pick over the cap or too fast; 413 for a body over :data:`MAX_BODY_BYTES`. A refused
request changes nothing stored but its count. ``/docs``, ``/redoc`` and ``/openapi.json`` answer
only when the app is made with ``api_docs=True`` (``scdp study serve --api-docs``).
"""

from __future__ import annotations

import time
from importlib import resources
from pathlib import Path
from typing import Literal

from fastapi import FastAPI, Request, Response
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel, ConfigDict, Field

from scdp.keys import MAX_GOALS
from scdp.serve.errors import error_response, install_error_handlers
from scdp.serve.limits import BodyLimit
from scdp.study import questions
from scdp.study.record import Study
from scdp.study.server import Refused, StudyServer
from scdp.study.store import Store

PAGE_SCRIPTS = ("page_draw.js", "page.js")  # inlined in this order: page.js runs the page, page_draw.js only defines

PID_PATTERN = r"^[A-Za-z0-9_.-]{1,64}$"
PLATFORM_ID = r"^[A-Za-z0-9_.-]{0,64}$"
SESSION_COOKIE = "scdp_study_"  # + the participant's ID: one session per ID in a browser
MAX_BODY_BYTES = 16 * 1024  # the largest honest body is a few hundred bytes
CONSENT_FILE = "consent.html"  # in the study folder: the consent text your ethics board approved
DEBRIEF_FILE = "debrief.html"  # in the study folder: what the study was about, shown at the end
DEFAULT_CONSENT = ("<p><b>Placeholder consent text.</b> The researcher running this study replaces it with the "
                   "consent form their ethics board approved, as <code>consent.html</code> in the study folder "
                   "(docs/study.md).</p><p>You will watch short animations of a robot and say which goal it is heading "
                   "to. It takes a few minutes. What is stored: the IDs in your link, your answers, how sure you were, "
                   "your ratings, their times, and whether the page stayed in view while the robot moved; nothing "
                   "else.</p>")


class Who(BaseModel):
    model_config = ConfigDict(extra="forbid")
    pid: str = Field(pattern=PID_PATTERN, description="the participant's ID (letters, digits, _ . -; at most 64)")


class AtTrial(Who):
    trial: int = Field(ge=0, le=10_000, description="the trial's index (0 is the practice)")


class Pick(AtTrial):
    goal: int = Field(ge=0, lt=MAX_GOALS, description="the goal clicked, by its position in the trial's goal list")
    t: float = Field(ge=0.0, le=3600.0, allow_inf_nan=False, description="seconds of the motion the page showed")


class Consent(Who):
    study_id: str = Field("", pattern=PLATFORM_ID, description="the platform's study ID (Prolific's STUDY_ID)")
    session_id: str = Field("", pattern=PLATFORM_ID, description="the platform's session ID (Prolific's SESSION_ID)")


class Answers(Who):
    answers: list[int] = Field(max_length=20, description="one option index per comprehension question")


class Focus(AtTrial):
    event: Literal["hidden", "blur"] = Field(description="the page was hidden (tab switched) or lost focus")


class Confirm(AtTrial):
    confidence: int = Field(ge=1, le=len(questions.CONFIDENCE), description="1 (a guess) to 5 (certain)")


class Rating(BaseModel):
    model_config = ConfigDict(extra="forbid")
    item: int = Field(ge=0, le=10_000, description="the rated trial's index")
    legible: int = Field(ge=1, le=questions.SCALE)
    predictable: int = Field(ge=1, le=questions.SCALE)


class Ratings(Who):
    ratings: list[Rating] = Field(max_length=20)


def _cookie(pid: str) -> str:
    return SESSION_COOKIE + pid


def page_html() -> str:
    """The page as participants receive it: page.html with its scripts inlined, in order, as one script (one
    self-contained document)."""
    files = resources.files("scdp.study")
    script = "\n".join(files.joinpath(name).read_text(encoding="utf-8") for name in PAGE_SCRIPTS)
    return files.joinpath("page.html").read_text(encoding="utf-8").replace("//PAGE_JS", script)


def _insert(page: str, folder, name: str, default: str) -> str:
    file = Path(folder) / name
    text = file.read_text(encoding="utf-8") if file.is_file() else default
    return page.replace(f"<!--{name.split('.')[0].upper()}-->", text)


def create_app(study: Study, folder, store: Store, clock=time.time, api_docs: bool = False) -> FastAPI:
    """The study's web app: the page, its JSON routes and the stimuli's frames (and the API's own
    documentation pages when ``api_docs``)."""
    server = StudyServer(study, store, clock=clock)
    docs = {} if api_docs else {"docs_url": None, "redoc_url": None, "openapi_url": None}
    app = FastAPI(title=f"scdp study: {study.task}", description="An online observer study of robot motion "
                                                                    "(scdp study serve --help).", **docs)
    install_error_handlers(app)
    app.add_middleware(BodyLimit, max_bytes=MAX_BODY_BYTES)
    page = _insert(_insert(page_html(), folder, CONSENT_FILE, DEFAULT_CONSENT), folder, DEBRIEF_FILE,
                   questions.DEFAULT_DEBRIEF)

    @app.exception_handler(Refused)
    async def refused(request: Request, exc: Refused):
        return error_response(exc.status, exc.field, exc.message)

    @app.get("/", response_class=HTMLResponse, include_in_schema=False)
    def index() -> Response:
        return HTMLResponse(page, headers={"Cache-Control": "no-store"})

    def session(request: Request, pid: str) -> str | None:
        return request.cookies.get(_cookie(pid))

    @app.post("/api/state")
    def state(who: Who, request: Request) -> dict:
        return server.state(who.pid, session(request, who.pid))

    @app.post("/api/consent")
    def consent(who: Consent, request: Request, response: Response) -> dict:
        out, token = server.consent(who.pid, session(request, who.pid), (who.study_id, who.session_id))
        if token:
            response.set_cookie(_cookie(who.pid), token, httponly=True, samesite="strict",
                                secure=request.url.scheme == "https", max_age=7 * 24 * 3600)
        return out

    @app.post("/api/decline")
    def decline(who: Who) -> dict:
        return server.decline(who.pid)

    @app.post("/api/comprehension")
    def comprehension(a: Answers, request: Request) -> dict:
        return server.comprehend(a.pid, session(request, a.pid), a.answers)

    @app.post("/api/motion")
    def play(at: AtTrial, request: Request) -> dict:
        return server.motion(at.pid, session(request, at.pid), at.trial)

    @app.post("/api/pick")
    def pick(p: Pick, request: Request) -> dict:
        return server.pick(p.pid, session(request, p.pid), p.trial, p.goal, p.t)

    @app.post("/api/focus")
    def focus(f: Focus, request: Request) -> dict:
        return server.focus(f.pid, session(request, f.pid), f.trial, f.event)

    @app.post("/api/response")
    def confirm(c: Confirm, request: Request) -> dict:
        return server.confirm(c.pid, session(request, c.pid), c.trial, c.confidence)

    @app.post("/api/ratings")
    def rate(r: Ratings, request: Request) -> dict:
        return server.rate(r.pid, session(request, r.pid), [x.model_dump() for x in r.ratings])

    frames = Path(folder) / "frames"
    if frames.is_dir():
        app.mount("/frames", StaticFiles(directory=frames), name="frames")
    return app
