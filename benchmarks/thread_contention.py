"""Does training degrade gracefully when the cores are shared? Steps/s of the cpu preset's base.

Regenerates: `results/benchmarks/thread_contention.md`

    python benchmarks/thread_contention.py [--seconds 25] [--out results/benchmarks/thread_contention.json]

Scenarios, each for three OpenMP wait policies: ``PASSIVE`` (idle threads sleep at once),
``ACTIVE`` (they spin: what an untuned torch process may do) and ``SHORT_SPIN`` (they spin for
``GOMP_SPINCOUNT=10000`` iterations, a few microseconds, then sleep):

* ``alone``: one training process;
* ``beside_busy``: the same, beside one single-threaded pure-Python busy loop;
* ``two_trainings``: two training processes at once (each reported, and their sum);
* ``latency``: alone, milliseconds of one batch-1 chunk of the cpu preset's base (DDPM-20,
  untrained weights): planning is many small kernels, where waking sleeping threads costs most.

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

DEFAULT_POLICY = "PASSIVE"  # what scdp.threads sets unless the user chose a policy

WORKER = "worker"
BUSY = "busy"
LATENCY = "latency"
POLICIES = {"PASSIVE": {"OMP_WAIT_POLICY": "PASSIVE"}, "ACTIVE": {"OMP_WAIT_POLICY": "ACTIVE"},
            "SHORT_SPIN": {"GOMP_SPINCOUNT": "10000"}}


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


def latency() -> None:
    import torch

    from scdp.policies.base import observe_histories
    from scdp.presets import get_preset
    from scdp.tasks import get_task
    from scdp.training.parts import build_diffusion

    task = get_task("navigation")
    policy = build_diffusion(task, get_preset("cpu")).eval()
    obs = observe_histories(task, [task.nominal_start()[None]], [[[2.0, 0.3], [2.0, -0.3]]], [0], policy.n_obs_steps)
    times = []
    for k in range(13):
        t0 = time.perf_counter()
        with torch.inference_mode():
            policy.act(obs, [torch.Generator().manual_seed(k)])
        times.append(time.perf_counter() - t0)
    print(json.dumps({"chunk_ms": 1000 * sorted(times[3:])[len(times[3:]) // 2]}), flush=True)


def busy() -> None:
    x = 0
    while True:
        x += 1


def run(scenario: str, policy: str, seconds: float) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")} | POLICIES[policy]
    if scenario == LATENCY:
        out = subprocess.run([sys.executable, __file__, f"--{LATENCY}"], env=env, capture_output=True, text=True, check=True)
        return {"scenario": scenario, "wait_policy": policy, **json.loads(out.stdout.strip().splitlines()[-1])}
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
    parser.add_argument(f"--{LATENCY}", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args.seconds)
    if args.busy:
        return busy()
    if args.latency:
        return latency()
    t0 = time.perf_counter()
    rows = []
    for p in POLICIES:
        for s in ("alone", "beside_busy", "two_trainings", LATENCY):
            rows.append(run(s, p, args.seconds))
            print(rows[-1], flush=True)
    by = {(r["wait_policy"], r["scenario"]): r for r in rows}
    summary = {}
    for p in POLICIES:
        alone = by[(p, "alone")]["total_steps_per_s"]
        summary[p] = {"slowdown_beside_busy": round(alone / by[(p, "beside_busy")]["total_steps_per_s"], 2),
                      "two_at_once_vs_one_after_other": round(by[(p, "two_trainings")]["total_steps_per_s"] / alone, 2),
                      "chunk_ms_batch1": round(by[(p, LATENCY)]["chunk_ms"], 1), "train_steps_per_s_alone": alone}
    default = DEFAULT_POLICY
    meets = summary[default]["slowdown_beside_busy"] <= 2.5 and summary[default]["two_at_once_vs_one_after_other"] >= 1.0
    out = {"command": "python benchmarks/thread_contention.py", "cores": os.cpu_count(), "rows": rows, "summary": summary,
           "default_policy": default, "default_meets_bounds": meets, "compute_minutes": round((time.perf_counter() - t0) / 60, 1)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=2) + "\n")
    lines = ["# Training beside other processes (cpu preset Navigation base, optimiser steps/s)", "",
             f"`python benchmarks/thread_contention.py`, {os.cpu_count()} cores, {args.seconds:g} s per measurement.", "",
             "| wait policy | scenario | steps/s per process | total |", "|---|---|---|---|"]
    lines += [f"| {r['wait_policy']} | {r['scenario']} | {r['steps_per_s']} | {r['total_steps_per_s']} |" for r in rows
              if r["scenario"] != LATENCY]
    lines += ["", "| wait policy | training alone, steps/s | slowdown beside one busy process | two at once / one alone | "
              "batch-1 chunk, ms |", "|---|---|---|---|---|"]
    lines += [f"| {p} | {v['train_steps_per_s_alone']} | {v['slowdown_beside_busy']}x | {v['two_at_once_vs_one_after_other']} | "
              f"{v['chunk_ms_batch1']} |" for p, v in summary.items()]
    lines += ["", f"Default ({default}, `scdp.threads`) meets the bounds (<= 2.5x, >= 1.0): {'yes' if meets else '**no**'}."]
    args.out.with_suffix(".md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
