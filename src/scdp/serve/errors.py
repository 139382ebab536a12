"""Every refusal of the planning service, and of the study's web app (:mod:`scdp.study.app` installs the
same handlers), as ``{"error": "<field>: <problem>"}``: one line, short.

* a request that does not fit the schema (a missing key, ``"target": "1"``, an unknown key):
  422, the field being the request's top-level key and the position inside it in the problem;
* a body that is not JSON: 422 on ``body``, with the parser's reason but no character offset;
* a body FastAPI cannot parse at all (nested too deep for the JSON parser, too large a number):
  422 on ``body``, not FastAPI's 400 ``{"detail": ...}``;
* a :class:`~scdp.errors.ScdpError` raised by the service (a state out of bounds, a chunk that
  failed its final check): 422 with its field;
* :class:`~scdp.serve.batcher.Busy`: 503 with ``Retry-After``; an unknown path or HTTP method:
  its status (404, 405) in the same form.

No message echoes more than a short prefix of a bad value (:mod:`scdp.messages`).
"""

from __future__ import annotations

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException

from scdp.errors import ScdpError
from scdp.messages import PREVIEW_CHARS, one_line, preview
from scdp.serve.batcher import Busy


def error_response(status: int, field: str, problem: str, headers: dict | None = None) -> JSONResponse:
    """The service's one error form."""
    return JSONResponse(status_code=status, content={"error": one_line(f"{field}: {problem}")}, headers=headers)


def _position(part) -> str:
    text = str(part)
    return text if len(text) <= PREVIEW_CHARS else preview(text)


def validation_message(errors: list) -> tuple[str, str]:
    """(field, problem) of the first schema error: the request's key (a nested one dotted, as in
    ``previous.plan``), then the position inside it."""
    first = errors[0] if errors else {"loc": ("body",), "msg": "malformed request"}
    loc = [p for p in first.get("loc", ()) if p != "body"]
    if first.get("type") == "json_invalid":  # loc holds a character offset, not a field
        reason = (first.get("ctx") or {}).get("error", "")
        return "body", f"not valid JSON ({one_line(reason, 120)})" if reason else "not valid JSON"
    if not loc:
        return "body", first.get("msg", "invalid")
    if len(str(loc[0])) > PREVIEW_CHARS:  # an unknown key too long to be a field name
        return "body", f"key {preview(str(loc[0]))}: {first.get('msg', 'invalid')}"
    keys = 1
    while keys < len(loc) and isinstance(loc[keys], str) and len(loc[keys]) <= PREVIEW_CHARS:
        keys += 1  # a field of a nested object
    inside = "".join(f"[{_position(p)}]" for p in loc[keys:])
    return ".".join(map(str, loc[:keys])), f"{'at ' + inside + ': ' if inside else ''}{first.get('msg', 'invalid')}"


def install_error_handlers(app: FastAPI) -> None:
    """Register the handlers above on ``app``."""

    @app.exception_handler(RequestValidationError)
    async def malformed(request: Request, exc: RequestValidationError):
        return error_response(422, *validation_message(exc.errors()))

    @app.exception_handler(ScdpError)
    async def refused(request: Request, exc: ScdpError):
        return error_response(422, exc.field, exc.message)

    @app.exception_handler(Busy)
    async def busy(request: Request, exc: Busy):
        return error_response(503, "busy", str(exc), headers={"Retry-After": "1"})

    @app.exception_handler(HTTPException)
    async def http_error(request: Request, exc: HTTPException):
        if exc.status_code == 400:  # FastAPI's "There was an error parsing the body"
            cause = exc.__cause__
            if isinstance(cause, RecursionError):
                problem = "nested too deeply to parse"
            elif isinstance(cause, ValueError):  # e.g. an integer of more digits than Python converts
                problem = f"could not be parsed ({one_line(str(cause), 80)})"
            else:
                problem = "could not be parsed"
            return error_response(422, "body", problem)
        where = "http_method" if exc.status_code == 405 else "path"
        return error_response(exc.status_code, where, str(exc.detail), headers=getattr(exc, "headers", None))
