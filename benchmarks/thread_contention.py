"""Does training degrade gracefully when the cores are shared? Steps/s of the cpu preset's base.

    python benchmarks/thread_contention.py [--seconds 25] [--out results/benchmarks/thread_contention.json]

Scenarios, each for the default thread policy (``OMP_WAIT_POLICY=PASSIVE``, :mod:`scdp.threads`)
and for OpenMP's spinning policy (``ACTIVE``, what an untuned torch process may do):

* ``alone``: one training process;
* ``beside_busy``: the same, beside one single-threaded pure-Python busy loop;
* ``two_trainings``: two training processes at once (each reported, and their sum).

A training process builds the cpu preset's Navigation base on 50 generated demos and trains
for ``--seconds`` after a short warm-up; it reports optimiser steps per second. Run it alone on
the machine. The bounds of issue 11: beside one busy process no worse than about 2.5x slower
than alone, and two at once together at least as fast as one alone.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

WORKER = "worker"
BUSY = "busy"


def worker(seconds: float) -> None:
    import torch

    from scdp.data.generate import generate_demos
    from scdp.data.windows import WindowData
    from scdp.presets import get_preset
    from scdp.tasks import get_task
    from scdp.training.parts import build_diffusion

    task, preset = get_task("navigation"), get_preset("cpu")
    dataset, _ = generate_demos(task, 50, 0, progress=False)
    model = preset.base.model
    data = WindowData(dataset, model.n_obs_steps, model.horizon, task)
    policy = build_diffusion(task, preset, data)
    opt = torch.optim.AdamW(policy.parameters(), lr=1e-4)
    gen = torch.Generator().manual_seed(0)

    def step():
        batch = data.get(torch.randint(0, len(data), (preset.base.train.batch_size,), generator=gen))
        loss = policy.loss(batch, generator=gen)
        opt.zero_grad()
        loss.backward()
        opt.step()

    for _ in range(5):
        step()
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        step()
        n += 1
    print(json.dumps({"steps_per_s": n / (time.perf_counter() - t0), "threads": torch.get_num_threads()}), flush=True)


def busy() -> None:
    x = 0
    while True:
        x += 1


def run(scenario: str, policy: str, seconds: float) -> dict:
    env = {**os.environ, "OMP_WAIT_POLICY": policy}
    cmd = [sys.executable, __file__, f"--{WORKER}", "--seconds", str(seconds)]
    helper = None
    if scenario == "beside_busy":
        helper = subprocess.Popen([sys.executable, __file__, f"--{BUSY}"], env=env)
    procs = [subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, text=True)
             for _ in range(2 if scenario == "two_trainings" else 1)]
    speeds = [json.loads(p.communicate()[0].strip().splitlines()[-1])["steps_per_s"] for p in procs]
    if helper is not None:
        helper.kill()
        helper.wait()
    return {"scenario": scenario, "wait_policy": policy, "steps_per_s": [round(s, 2) for s in speeds],
            "total_steps_per_s": round(sum(speeds), 2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=25.0, help="timed training per process (default 25)")
    parser.add_argument("--out", type=Path, default=Path("results/benchmarks/thread_contention.json"))
    parser.add_argument(f"--{WORKER}", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument(f"--{BUSY}", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args.seconds)
    if args.busy:
        return busy()
    t0 = time.perf_counter()
    rows = [run(s, p, args.seconds) for p in ("PASSIVE", "ACTIVE") for s in ("alone", "beside_busy", "two_trainings")]
    for r in rows:
        print(r, flush=True)
    by = {(r["wait_policy"], r["scenario"]): r for r in rows}
    summary = {}
    for p in ("PASSIVE", "ACTIVE"):
        alone = by[(p, "alone")]["total_steps_per_s"]
        summary[p] = {"slowdown_beside_busy": round(alone / by[(p, "beside_busy")]["total_steps_per_s"], 2),
                      "two_at_once_vs_one_after_other": round(by[(p, "two_trainings")]["total_steps_per_s"] / alone, 2)}
    meets = summary["PASSIVE"]["slowdown_beside_busy"] <= 2.5 and summary["PASSIVE"]["two_at_once_vs_one_after_other"] >= 1.0
    out = {"command": "python benchmarks/thread_contention.py", "cores": os.cpu_count(), "rows": rows, "summary": summary,
           "default_meets_bounds": meets, "compute_minutes": round((time.perf_counter() - t0) / 60, 1)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=2) + "\n")
    lines = ["# Training beside other processes (cpu preset Navigation base, optimiser steps/s)", "",
             f"`python benchmarks/thread_contention.py`, {os.cpu_count()} cores, {args.seconds:g} s per measurement.", "",
             "| wait policy | scenario | steps/s per process | total |", "|---|---|---|---|"]
    lines += [f"| {r['wait_policy']} | {r['scenario']} | {r['steps_per_s']} | {r['total_steps_per_s']} |" for r in rows]
    lines += ["", "| wait policy | slowdown beside one busy process | two at once / one alone |", "|---|---|---|"]
    lines += [f"| {p} | {v['slowdown_beside_busy']}x | {v['two_at_once_vs_one_after_other']} |" for p, v in summary.items()]
    lines += ["", f"Default (PASSIVE) meets the bounds (<= 2.5x, >= 1.0): {'yes' if meets else '**no**'}."]
    args.out.with_suffix(".md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
