"""A cap on request bodies, for the planning service and the study's page alike.

A body larger than ``max_bytes`` is refused with 413 and the one-line error form
(``{"error": "body: ..."}``) before it is read whole: a declared ``Content-Length`` over the cap is
refused at once, and a chunked body is counted as it arrives and refused the moment it passes it.
Pure ASGI, so nothing above the cap is ever buffered.
"""

from __future__ import annotations

import json

from scdp.messages import one_line


class BodyLimit:
    """ASGI middleware: ``app.add_middleware(BodyLimit, max_bytes=...)``."""

    def __init__(self, app, max_bytes: int):
        self.app, self.max_bytes = app, int(max_bytes)

    async def _refuse(self, send) -> None:
        body = json.dumps({"error": one_line(f"body: larger than the {self.max_bytes} bytes this server reads")}).encode()
        await send({"type": "http.response.start", "status": 413,
                    "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                                (b"connection", b"close")]})
        await send({"type": "http.response.body", "body": body})

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        declared = dict(scope.get("headers") or []).get(b"content-length")
        if declared is not None and declared.isdigit() and int(declared) > self.max_bytes:
            return await self._refuse(send)
        seen, refused = 0, False

        async def counted_receive():
            nonlocal seen, refused
            message = await receive()
            if message["type"] == "http.request" and not refused:
                seen += len(message.get("body", b""))
                if seen > self.max_bytes:  # answer now; the app sees the client gone and stops reading
                    refused = True
                    await self._refuse(send)
                    return {"type": "http.disconnect"}
            return message

        async def guarded_send(message):
            if not refused:  # after the 413, whatever the app answers is dropped
                await send(message)

        await self.app(scope, counted_receive, guarded_send)
