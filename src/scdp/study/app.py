"""``scdp study serve``: the study's web app (FastAPI) over its rules (:mod:`scdp.study.server`).

The page (``page.html``, one self-contained file) talks to five JSON routes::

    POST /api/state     {"pid"}                          -> consent, a trial (goals only), or done
    POST /api/consent   {"pid"}                          -> the same, after recording consent; sets the session cookie
    POST /api/motion    {"pid", "trial"}                 -> the motion so far (the first call starts it)
    POST /api/pick      {"pid", "trial", "goal", "t"}    -> a goal clicked, at fraction t of the motion shown
    POST /api/response  {"pid", "trial"}                 -> confirms the last pick, then the state
    GET  /frames/<name>.jpg                               Block Reach frames (opaque names, revealed by /api/motion)

A participant's ID arrives as the page's query parameter (``?pid=...``, as crowdsourcing platforms
pass it); consent issues a session token, kept by the browser as an HTTP-only cookie, that every
later route requires (403 without it). The server, not the page, knows each trial's target, and
the page receives the path only as fast as the motion plays. Refusals follow the project's
contract, one line ``{"error": "<field>: <problem>"}``: 422 for a malformed body, a trial not
reached, a goal that does not exist, a Confirm before the motion ended; 403 without the session;
409 for a trial already confirmed; 413 for a body over :data:`MAX_BODY_BYTES`. A refused
request changes nothing stored.
"""

from __future__ import annotations

import time
from importlib import resources
from pathlib import Path

from fastapi import FastAPI, Request, Response
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel, ConfigDict, Field

from scdp.keys import MAX_GOALS
from scdp.serve.errors import error_response, install_error_handlers
from scdp.serve.limits import BodyLimit
from scdp.study.record import Study
from scdp.study.server import Refused, StudyServer
from scdp.study.store import Store

PID_PATTERN = r"^[A-Za-z0-9_.-]{1,64}$"
SESSION_COOKIE = "scdp_study_session"
MAX_BODY_BYTES = 16 * 1024  # the largest honest body is a few hundred bytes
CONSENT_FILE = "consent.html"  # in the study folder: the consent text your ethics board approved
DEFAULT_CONSENT = ("<p><b>Placeholder consent text.</b> The researcher running this study replaces it with the "
                   "consent form their ethics board approved, as <code>consent.html</code> in the study folder "
                   "(docs/study.md).</p><p>You will watch short animations of a robot and say which goal it is heading "
                   "to. It takes a few minutes. What is stored: the ID in your link, your answers and their times, "
                   "nothing else.</p>")


class Who(BaseModel):
    model_config = ConfigDict(extra="forbid")
    pid: str = Field(pattern=PID_PATTERN, description="the participant's ID (letters, digits, _ . -; at most 64)")


class AtTrial(Who):
    trial: int = Field(ge=0, le=10_000, description="the trial's index (0 is the practice)")


class Pick(AtTrial):
    goal: int = Field(ge=0, lt=MAX_GOALS, description="the goal clicked, by its position in the trial's goal list")
    t: float = Field(ge=0.0, le=1.0, allow_inf_nan=False, description="fraction of the motion the page showed")


def page_html() -> str:
    return resources.files("scdp.study").joinpath("page.html").read_text(encoding="utf-8")


def create_app(study: Study, folder, store: Store, clock=time.time) -> FastAPI:
    """The study's web app: the page, its JSON routes and the stimuli's frames."""
    server = StudyServer(study, store, clock=clock)
    app = FastAPI(title=f"scdp study: {study.task}", description="An online observer study of robot motion "
                                                                    "(scdp study serve --help).")
    install_error_handlers(app)
    app.add_middleware(BodyLimit, max_bytes=MAX_BODY_BYTES)
    consent_file = Path(folder) / CONSENT_FILE
    page = page_html().replace("<!--CONSENT-->", consent_file.read_text(encoding="utf-8") if consent_file.is_file()
                               else DEFAULT_CONSENT)

    @app.exception_handler(Refused)
    async def refused(request: Request, exc: Refused):
        return error_response(exc.status, exc.field, exc.message)

    @app.get("/", response_class=HTMLResponse, include_in_schema=False)
    def index() -> Response:
        return HTMLResponse(page, headers={"Cache-Control": "no-store"})

    @app.post("/api/state")
    def state(who: Who, request: Request) -> dict:
        return server.state(who.pid, request.cookies.get(SESSION_COOKIE))

    @app.post("/api/consent")
    def consent(who: Who, request: Request, response: Response) -> dict:
        out, token = server.consent(who.pid, request.cookies.get(SESSION_COOKIE))
        if token:
            response.set_cookie(SESSION_COOKIE, token, httponly=True, samesite="strict",
                                secure=request.url.scheme == "https", max_age=7 * 24 * 3600)
        return out

    @app.post("/api/motion")
    def play(at: AtTrial, request: Request) -> dict:
        return server.motion(at.pid, request.cookies.get(SESSION_COOKIE), at.trial)

    @app.post("/api/pick")
    def pick(p: Pick, request: Request) -> dict:
        return server.pick(p.pid, request.cookies.get(SESSION_COOKIE), p.trial, p.goal, p.t)

    @app.post("/api/response")
    def confirm(at: AtTrial, request: Request) -> dict:
        return server.confirm(at.pid, request.cookies.get(SESSION_COOKIE), at.trial)

    frames = Path(folder) / "frames"
    if frames.is_dir():
        app.mount("/frames", StaticFiles(directory=frames), name="frames")
    return app
