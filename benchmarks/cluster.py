"""The confirmation on one worker and on two, and on paper on N machines.

Regenerates: `results/benchmarks/cluster.md`, `results/benchmarks/cluster.json`

    python benchmarks/cluster.py [--preset tiny] [--work runs/cluster] [--times results/cpu/stage_times.json]

1. **Measured here.** The confirmation's shape (``benchmarks/confirm.sh``: three training seeds, both
   tasks, ``--seeds 0 1 2 --set evaluation.seed=11``) from scratch, with ``--preset`` (tiny: the cpu
   preset's every stage at a size that runs in minutes, since the cpu preset's takes hours per seed),
   three ways, each a fresh process with nothing else running: the local executor with this machine's
   threads; Ray with 1 worker CPU; Ray with 2. Both Ray runs compute with one thread per unit
   (``scdp --threads 1``), so each worker CPU holds one unit. Wall seconds include starting Ray.
2. **On paper.** The same confirmation with the cpu preset on N machines of one unit each, from the
   stage times a cpu run recorded (``--times``): each phase of units (shared stages; each model set;
   each evaluation, :func:`scdp.pipeline.plan.stage_phases`) is spread over the N workers longest
   first, and the phases follow one another. Seed 0 reuses the committed models, so only its
   evaluations run, as in ``confirm.sh``. Copying and waiting for shared storage are not counted.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

from scdp.io import write_json, write_text
from scdp.pipeline.executor import local_threads
from scdp.pipeline.plan import plan_stages, stage_phases
from scdp.presets import get_preset
from scdp.tasks import TASKS, get_task

sys.path.insert(0, str(Path(__file__).parent))
from realtime import matmul_gflops  # noqa: E402 (a sibling benchmark)

SEEDS = (0, 1, 2)
EVALUATION_SEED = 11  # the confirmation's untouched evaluation seed (confirm.sh)
NODES = (1, 2, 3, 6, 12)


def timed_run(preset: str, out: Path, extra: list[str], threads: list[str]) -> float:
    shutil.rmtree(out, ignore_errors=True)
    command = [sys.executable, "-m", "scdp", *threads, "reproduce", "--task", "all", "--preset", preset, "--seeds",
               *map(str, SEEDS), "--set", f"evaluation.seed={EVALUATION_SEED}", "--out", str(out), *extra]
    start = time.perf_counter()
    with open(out.with_suffix(".log"), "w") as log:
        subprocess.run(command, check=True, stdout=log, stderr=subprocess.STDOUT)
    return round(time.perf_counter() - start, 1)


def makespan(durations: list[float], workers: int) -> float:
    """Longest-first list scheduling of independent units on ``workers``: the last one's end."""
    loads = [0.0] * workers
    for d in sorted(durations, reverse=True):
        loads[loads.index(min(loads))] += d
    return max(loads)


def paper_estimate(times: dict) -> dict:
    """Hours of the cpu-preset confirmation on N one-unit workers, from one run's stage seconds."""
    preset = get_preset("cpu")
    phases: list[list[float]] = [[], [], []]
    for name in TASKS:
        plan = plan_stages(get_task(name), preset, Path("x") / name)
        for phase, groups in enumerate(stage_phases(plan)):
            for group in groups:
                seconds = sum(times.get(f"{name}/{stage}", 0.0) for stage in group)
                seeds = len(SEEDS) if phase == 2 else len(SEEDS) - 1  # seed 0: the committed models, evaluated
                phases[phase] += [seconds] * seeds
    total = sum(map(sum, phases))
    return {"compute_hours": round(total / 3600, 2), "units": [len(p) for p in phases],
            "hours_on": {n: round(sum(makespan(p, n) for p in phases if p) / 3600, 2) for n in NODES},
            "longest_unit_hours": round(max(max(p) for p in phases if p) / 3600, 2)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="tiny", help="the measured runs' preset (default tiny)")
    ap.add_argument("--work", type=Path, default=Path("runs/cluster"), help="where the measured runs go (default runs/cluster)")
    ap.add_argument("--times", type=Path, default=Path("results/cpu/stage_times.json"),
                    help="a cpu run's stage seconds for the estimate (default results/cpu/stage_times.json)")
    ap.add_argument("--out", type=Path, default=Path("results/benchmarks/cluster.md"))
    args = ap.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    threads = local_threads()
    runs = {f"local executor, {threads} threads": timed_run(args.preset, args.work / "local", [], []),
            "Ray, 1 worker CPU, 1 thread per unit": timed_run(args.preset, args.work / "ray1",
                                                              ["--executor", "ray", "--workers", "1"], ["--threads", "1"]),
            "Ray, 2 worker CPUs, 1 thread per unit": timed_run(args.preset, args.work / "ray2",
                                                               ["--executor", "ray", "--workers", "2"], ["--threads", "1"])}
    one, two, local = runs["Ray, 1 worker CPU, 1 thread per unit"], runs["Ray, 2 worker CPUs, 1 thread per unit"], \
        runs[f"local executor, {threads} threads"]
    estimate = paper_estimate(json.loads(args.times.read_text()))
    gflops = matmul_gflops()
    write_json(args.out.with_suffix(".json"), {"preset": args.preset, "seeds": list(SEEDS), "wall_seconds": runs,
                                               "two_over_one": round(two / one, 3), "two_over_local": round(two / local, 3),
                                               "estimate_cpu_preset": estimate, "times": str(args.times),
                                               "matmul_gflops": gflops})
    lines = ["# The confirmation on a cluster", "",
             f"`python benchmarks/cluster.py --preset {args.preset}`. The confirmation's shape (3 training seeds, both "
             f"tasks, evaluation seed {EVALUATION_SEED}) from scratch with the {args.preset} preset on this machine "
             f"({threads} cores, fp32 matmul {gflops:.0f} GFLOP/s), each run alone:", "", "| run | wall s |", "|---|---|",
             *[f"| {k} | {v} |" for k, v in runs.items()], "",
             f"Two workers against one: **{two / one:.2f}x** the wall time; against the local executor: {two / local:.2f}x.",
             "", f"## On paper: the cpu preset's confirmation on N workers (from `{args.times}`)", "",
             f"{estimate['compute_hours']} compute-hours in {sum(estimate['units'])} units (phases of "
             f"{', '.join(map(str, estimate['units']))}); the longest unit {estimate['longest_unit_hours']} h, so no "
             "number of workers finishes sooner than the sum of each phase's longest unit.", "",
             "| workers | hours |", "|---|---|", *[f"| {n} | {h} |" for n, h in estimate["hours_on"].items()], ""]
    write_text(args.out, "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
