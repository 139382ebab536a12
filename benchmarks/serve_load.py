"""Load test of ``scdp serve`` on loopback: concurrent robots, malformed requests mixed in.

Regenerates: `results/benchmarks/serve_load.md`

    python benchmarks/serve_load.py --checkpoints runs/cpu/navigation/checkpoints --task navigation \
        [--clients 32 --requests 100] [--out results/benchmarks/serve_load]

Starts the service in a subprocess on a free loopback port, then:

1. one client alone sends ``--single`` act requests back to back (the unbatched rate), then drives
   ``--episodes`` robots one after another through ``--chunks`` chunks each, as a control loop does:
   each request carries the states the last chunk reached and sends the last answer back as
   ``previous`` (what a warm start, ``--serve-args "--warm-skip K"``, reads);
2. ``--clients`` clients each send ``--requests`` act requests at once, while one more client
   streams malformed requests (each must get a 422 with a one-line error);
3. checks that the service still answers ``/v1/health``.

Every act request is a valid scene from :func:`scdp.data.scenes.sample_scenes` with the start
state. Reports p50/p99 latency seen by the clients, throughput, errors on valid requests, the
server's mean batch size, and the batching gain: concurrent throughput / one-client throughput.
Writes ``OUT.json`` and ``OUT.md``. Run it alone: it times things.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import socket
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

import httpx
import numpy as np

from scdp.data.scenes import BENCHMARK, sample_scenes
from scdp.io import write_json, write_text
from scdp.tasks import get_task

MALFORMED = [  # bodies a confused client might send; all must get 422
    {"goals": [[2.0, 0.3], [2.0, -0.3]]},
    {"state_history": [[0.0, 0.0, 0.0]], "goals": [[2.0, 0.3]]},
    {"state_history": [[0.0, 0.0]], "goals": [[2.0, 0.3], [2.0, -0.3]]},
    {"state_history": [[0.0, 0.0, 0.0]], "goals": [[2.0, 0.3], [2.0, 0.3]]},
    {"state_history": [[0.0, 0.0, 0.0]], "goals": [[2.0, 0.3], [2.0, -0.3]], "target": 7},
    {"state_history": [[0.0, 0.0, 0.0]], "goals": [[2.0, 0.3], [2.0, -0.3]], "method": "rrt"},
    {"state_history": [[0.0, 0.0, 0.0]], "goals": [[2.0, 0.3], [2.0, -0.3]], "seed": -3},
    {"state_history": [["x", 0.0, 0.0]], "goals": [[2.0, 0.3], [2.0, -0.3]]},
    {"state_history": [[1e999, 0.0, 0.0]], "goals": [[2.0, 0.3], [2.0, -0.3]]},
    "not an object",
]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until_up(url: str, proc: subprocess.Popen, limit_s: float = 120.0, poll_s: float = 0.2) -> None:
    """Return once ``url``'s /v1/health answers 200 (asked every ``poll_s``); exit if ``proc`` dies or ``limit_s`` passes."""
    deadline = time.time() + limit_s
    while time.time() < deadline:
        if proc.poll() is not None:
            sys.exit(f"the server exited with {proc.returncode}")
        try:
            if httpx.get(f"{url}/v1/health", timeout=1.0).status_code == 200:
                return
        except httpx.HTTPError:
            time.sleep(poll_s)
    sys.exit("the server did not come up")


def act_bodies(task, n: int, seed: int, method: str) -> list[dict]:
    start = task.nominal_start().tolist()
    return [{"state_history": [start], "goals": np.asarray(goals).tolist(), "target": int(target), "method": method,
             "seed": i} for i, (goals, target) in enumerate(sample_scenes(task, n, seed, stream=BENCHMARK))]


def client_loop(url: str, bodies: list[dict], latencies: list, statuses: list, timeout_s: float) -> None:
    with httpx.Client(timeout=timeout_s) as client:
        for body in bodies:
            t0 = time.perf_counter()
            try:
                status = client.post(f"{url}/v1/act", json=body).status_code
            except httpx.HTTPError:
                status = -1
            latencies.append(1000 * (time.perf_counter() - t0))
            statuses.append(status)


NODELAY = [(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)]  # send the body with its headers (docs/service.md)


def http_client(timeout_s: float, nodelay: bool = False) -> httpx.Client:
    """An HTTP client as robot stacks make one: httpx's defaults, or with TCP_NODELAY, whose request
    body does not wait for the server's delayed acknowledgement of its headers (about 40 ms on Linux)."""
    return httpx.Client(timeout=timeout_s, transport=httpx.HTTPTransport(socket_options=NODELAY) if nodelay else None)


def episode_loop(url: str, bodies: list[dict], chunks: int, timeout_s: float, nodelay: bool = False) -> tuple[list, Counter]:
    """One robot per body, ``chunks`` act calls each, the robot reaching every action it is sent:
    (milliseconds of every call, how each chunk started)."""
    latencies, starts = [], Counter()
    with http_client(timeout_s, nodelay) as client:
        for body in bodies:
            history, previous = list(body["state_history"]), None
            for _ in range(chunks):
                t0 = time.perf_counter()
                r = client.post(f"{url}/v1/act", json={**body, "state_history": history[-8:], "previous": previous})
                latencies.append(1000 * (time.perf_counter() - t0))
                if r.status_code != 200:
                    starts[f"error {r.status_code}"] += 1
                    break
                answer = r.json()
                starts[answer["start"]] += 1
                history += answer["actions"]
                previous = {"plan": answer["plan"], "weight": answer["weight"], "executed": len(answer["actions"])}
    return latencies, starts


def malformed_loop(url: str, stop: threading.Event, answers: list) -> None:
    with httpx.Client(timeout=30.0) as client:
        k = 0
        while not stop.is_set():
            body = MALFORMED[k % len(MALFORMED)]
            r = client.post(f"{url}/v1/act", content=json.dumps(body), headers={"content-type": "application/json"})
            one_line = r.status_code == 422 and "\n" not in r.json().get("error", "\n")
            answers.append(one_line)
            k += 1
            time.sleep(0.01)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoints", type=Path, default=Path("runs/cpu/navigation/checkpoints"))
    parser.add_argument("--task", default="navigation")
    parser.add_argument("--method", default="scdp")
    parser.add_argument("--clients", type=int, default=32)
    parser.add_argument("--requests", type=int, default=100, help="act requests per concurrent client")
    parser.add_argument("--single", type=int, default=100, help="act requests of the lone client")
    parser.add_argument("--episodes", type=int, default=10, help="robots the lone client drives, one after another")
    parser.add_argument("--chunks", type=int, default=10, help="act calls per robot (a cpu-preset trajectory plans about 10)")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds per request before it counts as an error")
    parser.add_argument("--serve-args", default="", help="planning flags for the service, e.g. \"--runtime onnx --steps 8\"")
    parser.add_argument("--out", type=Path, default=Path("results/benchmarks/serve_load"))
    args = parser.parse_args()
    task = get_task(args.task)
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    proc = subprocess.Popen([sys.executable, "-m", "scdp", "serve", "--task", task.name, "--checkpoints", str(args.checkpoints),
                             "--port", str(port), *shlex.split(args.serve_args)], stdout=subprocess.DEVNULL)
    try:
        wait_until_up(url, proc)
        info = httpx.get(f"{url}/v1/info").json()
        bodies = act_bodies(task, args.single + args.clients * args.requests, seed=11, method=args.method)
        client_loop(url, bodies[:3], [], [], args.timeout)  # warm-up: planners load on first use

        single_lat, single_status = [], []
        t0 = time.perf_counter()
        client_loop(url, bodies[:args.single], single_lat, single_status, args.timeout)
        single_rps = args.single / (time.perf_counter() - t0)
        episode_lat, episode_starts = episode_loop(url, bodies[:args.episodes], args.chunks, args.timeout)

        lat, status, answers, stop = [], [], [], threading.Event()
        rest = bodies[args.single:]
        threads = [threading.Thread(target=client_loop, args=(url, rest[c::args.clients], lat, status, args.timeout))
                   for c in range(args.clients)]
        bad = threading.Thread(target=malformed_loop, args=(url, stop, answers))
        t0 = time.perf_counter()
        bad.start()
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        wall = time.perf_counter() - t0
        stop.set()
        bad.join()
        alive = httpx.get(f"{url}/v1/health", timeout=5.0).status_code == 200
        batching = httpx.get(f"{url}/v1/info").json()["batching"]
    finally:
        proc.terminate()
        proc.wait(timeout=30)

    concurrent_rps = len(status) / wall
    runtime = ", ".join(sorted({part.get("runtime", "torch") for part in info["parts"].values()}))
    summary = {
        "requests": len(status), "errors": int(sum(s != 200 for s in status)),
        "p50_ms": round(float(np.percentile(lat, 50)), 2), "p99_ms": round(float(np.percentile(lat, 99)), 2),
        "throughput_rps": round(concurrent_rps, 1), "single_client_rps": round(single_rps, 1),
        "single_client_p50_ms": round(float(np.percentile(single_lat, 50)), 2),
        "episode_p50_ms": round(float(np.percentile(episode_lat, 50)), 2),
        "episode_chunk_starts": ", ".join(f"{k} {v}" for k, v in sorted(episode_starts.items())),
        "batching_gain": round(concurrent_rps / single_rps, 2), "clients": args.clients,
        "malformed_sent": len(answers), "malformed_refused_one_line": int(sum(answers)), "alive_at_end": alive,
        "server_batching": batching, "method": args.method, "task": task.name, "preset": info["preset"],
        "sampler": info["sampler"], "inference_steps": info["inference_steps"], "runtime": runtime, "cpu_count": os.cpu_count(),
        "wall_seconds": round(wall, 1), "command": shlex.join(["python", "benchmarks/serve_load.py", *sys.argv[1:]]),
    }
    write_json(args.out.with_suffix(".json"), summary)
    lines = ["# Planning service under load (loopback)", "", f"`{summary['command']}`", "",
             f"{args.clients} concurrent clients x {args.requests} `act` requests ({args.method}, {task.name}, preset "
             f"{info['preset']}, {info['sampler']} {info['inference_steps']} steps, runtime {runtime}, {os.cpu_count()} CPU cores), with a "
             "stream of malformed requests mixed in.", "", "| measure | value |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in summary.items() if k not in ("command", "server_batching")]
    lines += [f"| server mean batch | {batching['mean_batch']} (largest {batching['largest_batch']}, "
              f"{batching['calls']} network calls) |"]
    write_text(args.out.with_suffix(".md"), "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
