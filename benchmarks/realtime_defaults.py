"""Latency with the defaults, as a user meets it: `scdp plan` and a warm `scdp serve`, nothing set.

Regenerates: `results/benchmarks/realtime_defaults.md`

    python benchmarks/realtime_defaults.py --run results/cpu [--scenes 10] [--out results/benchmarks/realtime_defaults]

Per task, ``--scenes`` validation scenes (seed 2), each planned by SCDP three ways, interleaved
scene by scene: ``scdp plan`` with no planning flag (the ``realtime`` profile: DDPM-8 warm-started
at step 4, ONNX Runtime where the checkpoints hold an exported graph), the same with ``--runtime
torch``, and with ``--profile trained`` (the checkpoints' own sampler, cold, torch: what the
default was). For each: the trajectory's planning seconds as ``scdp plan`` prints them, and the
command's whole wall time split into start-up (interpreter, imports, parsing: the wall time
not spent below), loading, the rollout (planning and environment stepping) and scoring. Then, for
Navigation, ``scdp serve`` with its defaults, warmed by one request: ``/v1/plan`` p50 over the same
scenes and ``/v1/act`` p50 of a lone client driving ``--scenes`` robots chunk by chunk, sending each
answer back (the warm start). Medians; the machine's fp32 matmul rate beside them. Run it alone.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from realtime import matmul_gflops  # sibling benchmarks
from serve_load import episode_loop, free_port, http_client, wait_until_up

from scdp.data.scenes import VALIDATION
from scdp.evaluation.protocol import scene_sets
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.tasks import get_task

WAYS = {"defaults": [], "defaults, --runtime torch": ["--runtime", "torch"], "--profile trained": ["--profile", "trained"]}
PARTS = ("startup", "loading", "rollout", "scoring")


def scenes_of(task, n: int, seed: int) -> list:
    sets = scene_sets(task, n, seed, stream=VALIDATION)
    both = [s for pair in zip(sets[AMBIGUOUS], sets[CLEAR]) for s in pair]
    return both[:n]


def plan_once(task, checkpoints: Path, goals, target: int, extra: list[str], out: Path) -> dict:
    """One ``scdp plan`` process: what it printed and recorded, and its whole wall time split."""
    command = [sys.executable, "-m", "scdp", "plan", "--task", task.name, "--checkpoints", str(checkpoints),
               "--goals", *(",".join(f"{v:.6f}" for v in g) for g in goals), "--target", str(target),
               "--out", str(out), "--force", *extra]
    t0 = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode:
        sys.exit(f"scdp plan failed: {done.stderr.strip()}")
    record = json.loads(out.read_text())
    inside = record["seconds"]
    return {"planning_s": record["planning_seconds"], "wall_s": wall, "startup": wall - sum(inside.values()), **inside,
            "success": record["success"], "warm": record["chunk_starts"].count("warm"), "chunks": len(record["chunk_starts"]),
            "planning": record["planning"], "printed": done.stdout.strip()}


def serve_latency(checkpoints: Path, task, scenes: list, chunks: int) -> dict:
    """A warm ``scdp serve`` with its defaults: ``/v1/plan`` and ``/v1/act`` p50 (and ``act`` p95), seen by
    an httpx client with its defaults and by one with TCP_NODELAY (``nodelay/``: no delayed-ACK wait)."""
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    proc = subprocess.Popen([sys.executable, "-m", "scdp", "serve", "--task", task.name, "--checkpoints", str(checkpoints),
                             "--methods", "scdp", "--port", str(port)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    out = {}
    try:
        wait_until_up(url, proc)
        bodies = [{"goals": np.asarray(g).tolist(), "target": int(t), "method": "scdp", "seed": i}
                  for i, (g, t) in enumerate(scenes)]
        start = task.nominal_start().tolist()
        for nodelay in (False, True):
            tag = "nodelay/" if nodelay else ""
            plan_ms, server_ms = [], []
            with http_client(120.0, nodelay) as client:
                out["planning"] = client.get(f"{url}/v1/info").json()["planning"]
                client.post(f"{url}/v1/plan", json=bodies[0]).raise_for_status()  # warm: the first request loads lazily
                for body in bodies:
                    t0 = time.perf_counter()
                    answer = client.post(f"{url}/v1/plan", json=body)
                    plan_ms.append(1000 * (time.perf_counter() - t0))
                    server_ms.append(answer.json()["server_ms"])
            act_ms, starts = episode_loop(url, [{"state_history": [start], **b} for b in bodies], chunks, 120.0, nodelay)
            out |= {f"{tag}plan_p50_ms": float(np.median(plan_ms)), f"{tag}plan_server_p50_ms": float(np.median(server_ms)),
                    f"{tag}act_p50_ms": float(np.median(act_ms)), f"{tag}act_p95_ms": float(np.percentile(act_ms, 95)),
                    f"{tag}act_starts": dict(starts)}
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    return out


def markdown(result: dict) -> str:
    lines = ["# Latency with the defaults: `scdp plan` and `scdp serve`, nothing set", "",
             f"`{result['command']}` ({result['compute_minutes']:.1f} compute-min; matmul {result['gflops']:.0f} GFLOP/s "
             f"fp32 on this machine, alone). Median of {result['scenes']} validation scenes per task, SCDP, one process per "
             "`scdp plan`; start-up is the wall time outside loading, the rollout and scoring.", ""]
    for name, block in result["tasks"].items():
        lines += [f"## {name}", "", "| `scdp plan` | planning s (as printed) | wall s | start-up | loading | rollout | scoring "
                  "| warm chunks | success | trained / this (planning) |", "|" + "---|" * 10]
        trained = block["--profile trained"]["planning_s"]
        for way in WAYS:
            r = block[way]
            lines.append(f"| {way} | {r['planning_s']:.3f} | {r['wall_s']:.2f} | " + " | ".join(f"{r[p]:.2f}" for p in PARTS)
                         + f" | {r['warm']:.0f}/{r['chunks']:.0f} | {r['success']:.2f} | {trained / r['planning_s']:.1f}x |")
        lines += ["", f"Planner under the defaults: `{block['defaults']['how']}`.", ""]
        if "serve" in block:
            s = block["serve"]
            lines += [f"`scdp serve` with its defaults, warm (scdp plans with {s['planning']['scdp']}):", "",
                      "| client | `/v1/plan` p50 ms (of which the server's) | `/v1/act` p50 ms | `/v1/act` p95 ms | chunk starts |",
                      "|---|---|---|---|---|"]
            for tag, name in (("", "httpx, its defaults"), ("nodelay/", "httpx with TCP_NODELAY")):
                lines.append(f"| {name} | {s[tag + 'plan_p50_ms']:.0f} ({s[tag + 'plan_server_p50_ms']:.0f}) | "
                             f"{s[tag + 'act_p50_ms']:.1f} | {s[tag + 'act_p95_ms']:.1f} | "
                             + ", ".join(f"{k} {v}" for k, v in sorted(s[tag + "act_starts"].items())) + " |")
            lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", type=Path, default=Path("results/cpu"), help="a reproduction (its <task>/checkpoints)")
    p.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    p.add_argument("--scenes", type=int, default=10, help="validation scenes per task (default 10)")
    p.add_argument("--chunks", type=int, default=10, help="/v1/act calls per robot (default 10)")
    p.add_argument("--seed", type=int, default=2)
    p.add_argument("--out", type=Path, default=Path("results/benchmarks/realtime_defaults"))
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    result = {"command": "python benchmarks/realtime_defaults.py " + " ".join(argv if argv is not None else sys.argv[1:]),
              "gflops": matmul_gflops(), "scenes": args.scenes, "tasks": {}}
    with tempfile.TemporaryDirectory(prefix="scdp-latency-") as work:
        for name in args.tasks:
            task, checkpoints = get_task(name), args.run / name / "checkpoints"
            runs = {way: [] for way in WAYS}
            for i, (goals, target) in enumerate(scenes_of(task, args.scenes, args.seed)):
                for way, extra in WAYS.items():
                    runs[way].append(plan_once(task, checkpoints, goals, target, extra, Path(work) / f"{i}.json"))
                print(name, i, {w: round(r[-1]["planning_s"], 3) for w, r in runs.items()}, flush=True)
            block = {}
            for way, rs in runs.items():
                block[way] = {k: float(np.median([r[k] for r in rs])) for k in ("planning_s", "wall_s", *PARTS, "warm", "chunks")}
                block[way]["success"] = float(np.mean([r["success"] for r in rs]))
                block[way]["how"] = json.dumps(rs[0]["planning"])
            if name == "navigation":
                block["serve"] = serve_latency(checkpoints, task, scenes_of(task, args.scenes, args.seed), args.chunks)
            result["tasks"][name] = block
    result["compute_minutes"] = (time.perf_counter() - t0) / 60
    write_json(args.out.with_suffix(".json"), result)
    write_text(args.out.with_suffix(".md"), markdown(result))
    print(markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
