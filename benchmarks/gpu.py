"""Planning and training speed on a CUDA GPU beside the same machine's CPU (issue 49): run by

Regenerates: `results/benchmarks/gpu.md`
``bash benchmarks/gpu.sh``, which runs the GPU tests first.

    python3 benchmarks/gpu.py --out results/benchmarks [--quick]

Measured, SCDP with its arbitration (Navigation), at two network sizes: ``cpu`` (the committed cpu
preset's checkpoints, ``results/cpu/navigation/checkpoints``) and ``paper`` (the paper preset's
65 M-parameter base and its predictors, untrained: speed does not depend on the weights):

* **chunk, batch 1**: one planning call, at DDPM-100 (the paper's sampler), DDPM-20 (the cpu
  preset's) and the fast planner (DDPM-8 warm-started at step 4; a warm chunk), on the CPU, on the
  GPU eager, and on the GPU replayed from a CUDA graph (the default there). Median of ``--reps``.
* **trajectory, batch 1**: ``cpu`` size: the planning seconds of one whole rollout of one scene
  (``scdp plan``'s path; one, after a warm-up rollout on the GPU); ``paper`` size (untrained nets
  cannot finish a rollout): 13 chunks, the cpu-preset Navigation trajectory's count, x the chunk.
* **batch 256**: trajectories' chunks per second at DDPM-20 (a 256-scene evaluation batch).
* **training**: the paper base's optimiser steps per second at batch 256 on the GPU (TF32, as
  ``scdp train`` runs there): the time of 260 steps less that of 60, over 200.

* **syncs per chunk** (cuda modes): the device-to-host synchronisations one warm batch-1 chunk
  makes, counted under ``torch.cuda.set_sync_debug_mode("warn")`` (one warning each): every one
  is host work waiting for the GPU (the arbitration's, kinematics' and warm-start checks' copies).

Every CUDA timing synchronises before reading the clock. Writes ``gpu.md`` and ``gpu.json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import torch

from scdp.config import PlanningOptions
from scdp.data.generate import generate_demos
from scdp.devices import describe
from scdp.evaluation.rollout import rollout
from scdp.policies.base import WarmStart, act, observe_histories
from scdp.policies.loaders import load_method
from scdp.policies.placement import place
from scdp.policies.scdp import StyleConditionedPolicy
from scdp.presets import get_preset
from scdp.tasks import get_task
from scdp.training import parts

TASK = get_task("navigation")
CHECKPOINTS = Path("results/cpu/navigation/checkpoints")
GOALS = ([[2.0, 0.3], [2.0, -0.3]], [[1.6, 0.1], [1.8, -0.5]], [[2.2, 0.0], [1.5, 0.6]], [[1.9, 0.45], [1.7, -0.25]])
SAMPLERS = {"DDPM-100": (100, 0), "DDPM-20": (20, 0), "fast (DDPM-8, warm at 4)": (8, 4)}
MODES = ("cpu", "cuda eager", "cuda graph")
TRAJECTORY_CHUNKS = 13  # the cpu-preset Navigation trajectory's chunks (issue 49's profile)


def planner(size: str, mode: str, steps: int, warm_skip: int):
    """SCDP of ``size`` on ``mode``'s device, sampling DDPM-``steps`` warm-started at ``warm_skip``."""
    device = "cpu" if mode == "cpu" else "cuda"
    options = PlanningOptions(sampler="ddpm", steps=steps, warm_skip=warm_skip, device=device, runtime="torch",
                              cuda_graphs="on" if mode == "cuda graph" else "off")
    if size == "cpu":
        scdp = load_method("scdp", CHECKPOINTS, TASK, options)
    else:
        preset = get_preset("paper")
        base = parts.build_diffusion(TASK, preset).to(device).eval()
        encoder = parts.build_encoder(TASK, preset).to(device).eval()
        styles = {s: parts.build_style(preset, base, encoder, f"style_{s}").to(device).eval() for s in ("legible", "efficient")}
        base.use_sampler("ddpm", steps).use_warm_start(warm_skip)
        scdp = StyleConditionedPolicy(base, encoder, styles, TASK, arbitration=preset.style.arbitration)
    scdp.base.place(place("torch", device, mode == "cuda graph", exported=False))
    return scdp


def scenes(batch: int, planner_):
    goals = [GOALS[i % len(GOALS)] for i in range(batch)]
    targets = [i % 2 for i in range(batch)]
    start = TASK.nominal_start()
    return goals, targets, observe_histories(TASK, [[start]] * batch, goals, targets, planner_.n_obs_steps)


def seconds(fn, device: str) -> float:
    if device != "cpu":
        torch.cuda.synchronize()
    t0 = time.perf_counter()
    fn()
    if device != "cpu":
        torch.cuda.synchronize()
    return time.perf_counter() - t0


def chunk_seconds(p, mode: str, batch: int, reps: int, warm: bool) -> float:
    """Median seconds of one planning call for ``batch`` scenes (a warm chunk when ``warm``), after a warm-up."""
    device = "cpu" if mode == "cpu" else "cuda"
    goals, targets, obs = scenes(batch, p)
    generators = [torch.Generator().manual_seed(i) for i in range(batch)]
    first = act(p, obs, generators)
    start = None
    if warm:  # the robots followed the first chunk: the next starts from its plan, re-noised
        moved = [[TASK.nominal_start(), *first.actions[b].double().numpy()] for b in range(batch)]
        obs = observe_histories(TASK, moved, goals, targets, p.n_obs_steps)
        start = WarmStart.from_chunk(first, p.n_action_steps)

    def call():
        return act(p, obs, generators, start)

    call()  # warm-up: lazy initialisation, the graph's capture
    return statistics.median(seconds(call, device) for _ in range(reps))


def syncs_per_chunk(p) -> int:
    """Device-to-host synchronisations of one batch-1 chunk after a warm-up chunk, as
    ``torch.cuda.set_sync_debug_mode("warn")`` reports them (a warning each)."""
    _, _, obs = scenes(1, p)
    act(p, obs, [torch.Generator().manual_seed(0)])  # warm-up: captures, lazy initialisation
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        torch.cuda.set_sync_debug_mode("warn")
        try:
            act(p, obs, [torch.Generator().manual_seed(0)])
        finally:
            torch.cuda.set_sync_debug_mode("default")
    return sum("synchroniz" in str(w.message).lower() for w in caught)


def trajectory_seconds(p, mode: str, reps: int) -> float:
    """Planning seconds of one whole rollout of one scene (the cpu size; median of ``reps``)."""
    runs = [rollout(TASK, p, [(GOALS[0], 0)], seed=0)[0].seconds for _ in range(reps + (mode != "cpu"))]
    return statistics.median(runs[1:] if mode != "cpu" else runs)


def training_steps_per_second(quick: bool) -> dict:
    """The paper base's optimiser steps per second at batch 256 on the GPU (TF32): (t(260) - t(60)) / 200."""
    demos, _ = generate_demos(TASK, 40, seed=0, progress=False)
    short, long = (10, 30) if quick else (60, 260)
    times, precision = {}, None
    for n in (short, long):
        preset = get_preset("paper").with_overrides(["base.train.epochs=1", f"base.train.min_steps={n}",
                                                     "base.train.checkpoint_every=100000"])
        with tempfile.TemporaryDirectory() as folder:
            t0 = time.perf_counter()
            _, result = parts.train_diffusion(TASK, demos, preset, Path(folder) / "base", progress=False, device="cuda")
            torch.cuda.synchronize()
            times[n] = time.perf_counter() - t0
            precision = result.precision
    return {"steps_per_second": round((long - short) / (times[long] - times[short]), 2), "precision": precision,
            "batch_size": 256, "steps": [short, long], "seconds": {str(k): round(v, 2) for k, v in times.items()}}


def measure(quick: bool, reps: int) -> dict:
    rows = []
    for size in ("cpu", "paper"):
        for name, (steps, skip) in SAMPLERS.items():
            if quick and steps == 100:
                continue
            for mode in MODES:
                if mode != "cpu" and not torch.cuda.is_available():
                    continue
                p = planner(size, mode, steps, skip)
                slow_cpu = mode == "cpu" and size == "paper"
                chunk = chunk_seconds(p, mode, 1, 1 if slow_cpu else reps, warm=skip > 0)
                if size == "cpu":
                    trajectory, how = trajectory_seconds(p, mode, 1), "rollout"
                else:
                    trajectory, how = TRAJECTORY_CHUNKS * chunk, f"{TRAJECTORY_CHUNKS} x chunk"
                row = {"size": size, "sampler": name, "mode": mode, "chunk_s": round(chunk, 4),
                       "trajectory_s": round(trajectory, 3), "trajectory": how}
                if mode != "cpu":
                    row["syncs_per_chunk"] = syncs_per_chunk(p)
                if steps == 20:
                    batch = 16 if quick else 256
                    per_chunk = chunk_seconds(p, mode, batch, 1 if mode == "cpu" else reps, warm=False)
                    row["batch"], row["batch_chunks_per_s"] = batch, round(batch / per_chunk, 1)
                rows.append(row)
                print(json.dumps(row), flush=True)
    training = training_steps_per_second(quick) if torch.cuda.is_available() else None
    return {"rows": rows, "training": training}


def markdown(result: dict) -> str:
    r = result
    lines = [f"# scdp on {r['device']}", "",
             f"`bash benchmarks/gpu.sh` ({r['when']}; torch {r['torch']}, CPU threads {r['cpu_threads']}; "
             f"{r['seconds']:.0f} s). SCDP (Navigation) with its arbitration; **cpu** size: the committed cpu checkpoints; "
             "**paper** size: the paper preset's nets, untrained. Chunk: one planning call at batch 1 (median); "
             "trajectory: the planning seconds of a whole one-scene rollout (cpu size) or 13 x the chunk (paper size). "
             "*cuda graph* is the default on a GPU (the DDPM loop replayed from one CUDA graph); *cuda eager* is the "
             "same planner with `cuda_graphs = False`.", "",
             f"GPU tests (`pytest -m gpu`): {r['tests']}", "",
             "| size | sampler | device | chunk, batch 1 (s) | trajectory, batch 1 (s) | scene-chunks/s in one batch | syncs per chunk |",
             "|---|---|---|---|---|---|---|"]
    for row in r["rows"]:
        batch = f"{row['batch_chunks_per_s']} (batch {row['batch']})" if "batch" in row else ""
        lines.append(f"| {row['size']} | {row['sampler']} | {row['mode']} | {row['chunk_s']:.4f} | {row['trajectory_s']:.3f} "
                     f"({row['trajectory']}) | {batch} | {row.get('syncs_per_chunk', '')} |")
    if r["training"]:
        t = r["training"]
        lines += ["", f"Training, the paper base at batch {t['batch_size']} on the GPU ({t['precision']}): "
                      f"**{t['steps_per_second']} steps/s** (({t['steps'][1]} - {t['steps'][0]}) steps in "
                      f"{t['seconds'][str(t['steps'][1])]} - {t['seconds'][str(t['steps'][0])]} s)."]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="results/benchmarks", help="folder for gpu.md and gpu.json (default results/benchmarks)")
    parser.add_argument("--reps", type=int, default=5, help="timed repetitions of a GPU chunk (default 5)")
    parser.add_argument("--tests", default="not run", help="what the GPU tests printed last (gpu.sh passes it)")
    parser.add_argument("--quick", action="store_true", help="a smoke run: no DDPM-100, small batches and training")
    args = parser.parse_args()
    started = time.perf_counter()
    result = measure(args.quick, args.reps)
    device = describe(torch.device("cuda")) if torch.cuda.is_available() else "cpu (no CUDA GPU)"
    result.update(device=device, torch=torch.__version__, cpu_threads=torch.get_num_threads(), tests=args.tests,
                  when=time.strftime("%Y-%m-%d"), seconds=round(time.perf_counter() - started, 1))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "gpu.json").write_text(json.dumps(result, indent=2) + "\n")
    (out / "gpu.md").write_text(markdown(result))
    print(markdown(result))


if __name__ == "__main__":
    main()
