"""The listening socket both HTTP apps (the planning service, the study) are served on.

Bound before the "serving" line, so a bad ``--host`` or a taken ``--port`` is the usual one-line
error with exit status 2, never a "serving" line followed by uvicorn's log.
"""

from __future__ import annotations

import socket

import uvicorn

from scdp.errors import ScdpError
from scdp.messages import preview

LOOPBACK = ("127.0.0.1", "localhost", "::1")


def resolve(host: str, port: int) -> tuple:
    """(family, address) to listen on for ``host``: the first address it resolves to."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except (socket.gaierror, UnicodeError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        raise ScdpError("--host", f"cannot resolve {preview(host)} ({reason})") from None
    family, _, _, _, address = infos[0]
    return family, address


def bind(host: str, port: int) -> socket.socket:
    """A socket bound to ``host:port`` (not yet listening; uvicorn listens on it)."""
    family, address = resolve(host, port)
    # IPPROTO_TCP, not 0: asyncio sets TCP_NODELAY on accepted connections only then; without it a
    # kept-alive client waits ~40 ms a call for its delayed ACK of the headers (tests/test_serve_socket.py)
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind(address)
    except OSError as exc:
        sock.close()
        raise ScdpError("--port", f"cannot listen on {preview(host)}:{port} ({exc.strerror or exc})") from None
    sock.set_inheritable(True)
    return sock


def run_app(app, sock: socket.socket) -> int:
    """Serve the ASGI ``app`` on the bound ``sock`` with uvicorn until interrupted."""
    uvicorn.Server(uvicorn.Config(app, log_level="warning")).run(sockets=[sock])
    return 0


def serve_app(app, host: str, port: int, banner: str, beyond: str) -> int:
    """The tail both servers share (``scdp serve``, ``scdp study serve``), after :func:`resolve` checked
    ``host`` and everything that can fail was loaded: bind, warn (``beyond``) when listening past
    loopback, print ``banner`` with ``{url}`` filled in, serve until interrupted."""
    sock = bind(host, port)
    if host not in LOOPBACK:
        print(f"scdp: warning: listening on {host}, beyond this machine; {beyond}")
    print(banner.replace("{url}", f"http://{host}:{sock.getsockname()[1]}"), flush=True)
    return run_app(app, sock)
