"""Kill -9 a full-size `scdp reproduce` at several points; the resumed run must match an uninterrupted one.

Regenerates: `results/benchmarks/kill_resume_cpu.json`

    python benchmarks/kill_resume.py [--preset cpu] [--seed 0] [--work runs/kill_resume] \
        [--reference DIR] [--out results/benchmarks/kill_resume_cpu.json]

The suite checks this on the tiny preset (tests/test_crash_safety.py); this is the by-hand check
of issue 11 on the cpu preset (about two reproductions: ~50 min on 2 cores). It runs:

1. a reference: one uninterrupted ``scdp reproduce --task all --preset P --seed S``;
2. the same command killed with SIGKILL a fixed number of seconds after each marker line (inside
   a training, a style stage, LD training and an evaluation), re-run after every kill, then run
   to the end.

``--reference DIR`` uses an existing uninterrupted run of the same command instead of step 1
(for example ``runs/cpu_seed1`` from ``scdp reproduce --task all --preset cpu --seed 1 --out
runs/cpu_seed1``, run on this machine with 2 threads). Both use the same thread count (float
reductions depend on it). It writes which kills happened,
the wall time of each attempt, and whether every random-protocol record's success and metrics are
identical between the two runs. Run it alone on the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

# (marker line prefix, seconds after it): mid-training, mid-style, mid-LD, mid-evaluation
KILLS = (("[navigation] stage base", 90.0), ("[navigation] stage style_legible", 40.0),
         ("[block_reach] stage ld", 60.0), ("[block_reach] stage evaluate", 60.0))


def command(preset: str, seed: int, out: Path) -> list[str]:
    return [sys.executable, "-m", "scdp", "reproduce", "--task", "all", "--preset", preset,
            "--seed", str(seed), "--out", str(out)]


def environment() -> dict:
    return {**os.environ, "PYTHONUNBUFFERED": "1", "OMP_NUM_THREADS": "2", "MKL_NUM_THREADS": "2"}


def scored(out: Path) -> dict:
    """(task, scene set, method, scene index) -> (success, metrics) of the random-protocol records."""
    data = json.loads((out / "results.json").read_text())
    return {f"{t['task']}/{t['scene_set']}/{t['method']}/{t['scene_index']}": [t["success"], t["metrics"]]
            for t in data["trajectories"] if t.get("protocol") in (None, "random")}


def run_to_end(cmd: list[str], log: Path) -> float:
    start = time.perf_counter()
    with log.open("a") as f:
        code = subprocess.run(cmd, env=environment(), stdout=f, stderr=subprocess.STDOUT).returncode
    if code != 0:
        sys.exit(f"kill_resume: error: {' '.join(cmd)} exited {code}; see {log}")
    return time.perf_counter() - start


def run_and_kill(cmd: list[str], marker: str, delay: float, log: Path) -> dict:
    """Run until `delay` seconds after the first line starting with `marker`, then SIGKILL."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, env=environment(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    timer = None
    with log.open("a") as f:
        for line in proc.stdout:
            f.write(line)
            if timer is None and line.startswith(marker):
                timer = threading.Timer(delay, proc.send_signal, (signal.SIGKILL,))
                timer.start()
    code = proc.wait()
    return {"marker": marker, "delay_s": delay, "killed": code == -signal.SIGKILL, "exit": code,
            "wall_s": round(time.perf_counter() - start, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="cpu")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--work", type=Path, default=Path("runs/kill_resume"))
    ap.add_argument("--reference", type=Path, help="an existing uninterrupted run of the same command (skips step 1)")
    ap.add_argument("--out", type=Path, default=Path("results/benchmarks/kill_resume_cpu.json"))
    args = ap.parse_args()
    if args.reference is not None and not (args.reference / "results.json").is_file():
        sys.exit(f"kill_resume: error: --reference: {args.reference}/results.json does not exist")
    if args.work.exists():
        shutil.rmtree(args.work)
    args.work.mkdir(parents=True)
    reference, killed = args.reference or args.work / "reference", args.work / "killed"
    log = args.work / "log.txt"

    ref_wall = None if args.reference else round(run_to_end(command(args.preset, args.seed, reference), log), 1)
    attempts = [run_and_kill(command(args.preset, args.seed, killed), marker, delay, log) for marker, delay in KILLS]
    final_wall = run_to_end(command(args.preset, args.seed, killed), log)

    a, b = scored(reference), scored(killed)
    differing = sorted(k for k in a if a[k] != b.get(k))
    report = {"preset": args.preset, "seed": args.seed, "command": " ".join(command(args.preset, args.seed, Path("OUT"))[1:]),
              "threads": 2, "reference": str(reference), "reference_wall_s": ref_wall, "kills": attempts,
              "final_attempt_wall_s": round(final_wall, 1), "records": len(a),
              "records_in_killed_run": len(b), "differing_records": len(differing) + len(set(b) - set(a)),
              "first_differences": differing[:10], "identical": a == b}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text(json.dumps(report, indent=2) + "\n")
    tmp.replace(args.out)
    print(json.dumps({k: report[k] for k in ("records", "differing_records", "identical")}))


if __name__ == "__main__":
    main()
