"""The listening socket both servers share (scdp.serve.listen): a kept-alive client is answered at once.

uvicorn writes a response's headers and body separately. Without TCP_NODELAY on the accepted
connection, Nagle's algorithm holds the body until the client acknowledges the headers, and a
kept-alive client delays that acknowledgement (about 40 ms on Linux). asyncio sets TCP_NODELAY on an
accepted connection only when the listening socket was made with protocol IPPROTO_TCP.
"""

from __future__ import annotations

import asyncio
import socket
import threading
import time

import httpx
import numpy as np
import uvicorn
from fastapi import FastAPI

from scdp.serve.listen import bind

CALLS = 30


def _nodelay_of_accepted(sock: socket.socket) -> int:
    """TCP_NODELAY of the connection asyncio accepts on ``sock`` (what uvicorn serves on)."""
    seen = []

    async def run():
        class Probe(asyncio.Protocol):
            def connection_made(self, transport):
                seen.append(transport.get_extra_info("socket").getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY))
                transport.close()

        server = await asyncio.get_running_loop().create_server(Probe, sock=sock)
        reader, writer = await asyncio.open_connection(*sock.getsockname()[:2])
        await reader.read()  # until the server closes it
        writer.close()
        server.close()
        await server.wait_closed()

    asyncio.run(run())
    return seen[0]


def test_accepted_connections_have_tcp_nodelay():
    assert _nodelay_of_accepted(bind("127.0.0.1", 0)) == 1


def test_the_nodelay_check_can_fail():
    plain = socket.socket(socket.AF_INET, socket.SOCK_STREAM)  # protocol 0, as bind() made it before
    plain.bind(("127.0.0.1", 0))
    assert _nodelay_of_accepted(plain) == 0


def _gap_ms(sock: socket.socket) -> float:
    """Median of (client round trip - the server's own time) over CALLS kept-alive calls, in ms."""
    app = FastAPI()

    @app.post("/echo")
    def echo(body: dict) -> dict:
        t0 = time.perf_counter()
        out = {"echo": body, "server_ms": 0.0}
        out["server_ms"] = 1000 * (time.perf_counter() - t0)
        return out

    server = uvicorn.Server(uvicorn.Config(app, log_level="warning"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        while not server.started:
            assert thread.is_alive()
            time.sleep(0.01)
        url = "http://%s:%d/echo" % sock.getsockname()[:2]
        gaps = []
        with httpx.Client(timeout=10.0) as client:  # one kept-alive connection, httpx's defaults
            client.post(url, json={"warm": 1})
            for i in range(CALLS):
                t0 = time.perf_counter()
                r = client.post(url, json={"state_history": [[0.0, 0.0, 0.0]] * 8, "i": i})
                gaps.append(1000 * (time.perf_counter() - t0) - r.json()["server_ms"])
        return float(np.median(gaps))
    finally:
        server.should_exit = True
        thread.join(timeout=10)


def test_a_kept_alive_client_waits_for_no_delayed_ack():
    """The client's round trip over the server's own time, as a difference: with TCP_NODELAY a few
    ms on loopback; without it the delayed acknowledgement adds about 40 ms a call."""
    assert _gap_ms(bind("127.0.0.1", 0)) < 15.0
