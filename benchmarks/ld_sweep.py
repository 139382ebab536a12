"""Tune Legibility Diffuser's guidance on validation scenes: maximise mean T subject to success >= 0.98.

    python benchmarks/ld_sweep.py --tasks navigation block_reach --checkpoints results/cpu [--scenes 20] [--seed 2]
        [--w0 1 2.5 5 10 20] [--alpha 0.5 0.9] [--decay 0.5 1] [--sampler ddim --steps 10]
        [--out results/cpu/ld_sweep.json]

``--checkpoints`` is a reproduction folder (``<task>/checkpoints/ld`` inside it). The scenes
(``--scenes`` ambiguous + ``--scenes`` clear per task, seed 2) are disjoint from the evaluation
scenes (seed 1). Every setting runs on the same scenes with the same noise. One guidance serves
every task (a preset has one): the chosen setting has the best T averaged over the tasks among
those whose success is >= 0.98 on every task (else the most successful). The JSON lists every
setting; the Markdown table beside it shows them best first.
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from pathlib import Path

import numpy as np

from scdp.config import GuidanceConfig
from scdp.evaluation.protocol import evaluate_methods, scene_sets
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR, SAMPLERS, TASK_NAMES
from scdp.policies.loaders import load_ld
from scdp.tasks import get_task

MIN_SUCCESS = 0.98
METRICS = ("transparency", "d_hat", "e_hat")


def score(task, folder, guidance, sets, seed, sampler, steps) -> dict:
    planner = load_ld(folder / task.name / "checkpoints" / "ld", task, guidance, sampler, steps)
    records = evaluate_methods(task, {"ld": planner}, sets, seed=seed, progress=False)
    out = {m: round(float(np.mean([r.metrics[m] for r in records])), 4) for m in METRICS}
    out["T_ambiguous"] = round(float(np.mean([r.metrics["transparency"] for r in records if r.scene_set == AMBIGUOUS])), 4)
    out["success"] = round(float(np.mean([r.success for r in records])), 4)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=list(TASK_NAMES), choices=list(TASK_NAMES))
    parser.add_argument("--checkpoints", required=True, type=Path, help="reproduction folder with <task>/checkpoints/ld")
    parser.add_argument("--scenes", type=int, default=20, help="per scene set and task (default 20)")
    parser.add_argument("--seed", type=int, default=2, help="scene seed (default 2: validation scenes)")
    parser.add_argument("--w0", type=float, nargs="+", default=[1.0, 2.5, 5.0, 10.0, 20.0])
    parser.add_argument("--alpha", type=float, nargs="+", default=[0.5, 0.9])
    parser.add_argument("--decay", type=float, nargs="+", default=[0.5, 1.0])
    parser.add_argument("--sampler", choices=SAMPLERS, help="replace the checkpoint's sampler")
    parser.add_argument("--steps", type=int, help="denoising steps of that sampler")
    parser.add_argument("--out", type=Path, default=Path("results/cpu/ld_sweep.json"))
    args = parser.parse_args()
    tasks = [get_task(t) for t in args.tasks]
    sets = {t.name: {k: v for k, v in scene_sets(t, args.scenes, args.seed).items() if k in (AMBIGUOUS, CLEAR)} for t in tasks}
    t0 = time.perf_counter()
    rows = []
    for w0, alpha, decay in itertools.product(args.w0, args.alpha, args.decay):
        guidance = GuidanceConfig(w0=w0, alpha=alpha, decay=decay)
        per_task = {t.name: score(t, args.checkpoints, guidance, sets[t.name], args.seed, args.sampler, args.steps) for t in tasks}
        row = {"w0": w0, "alpha": alpha, "decay": decay, "tasks": per_task,
               "mean_T": round(float(np.mean([v["transparency"] for v in per_task.values()])), 4),
               "min_success": min(v["success"] for v in per_task.values())}
        print(json.dumps(row), flush=True)
        rows.append(row)
    ok = [r for r in rows if r["min_success"] >= MIN_SUCCESS]
    chosen = max(ok, key=lambda r: r["mean_T"]) if ok else max(rows, key=lambda r: (r["min_success"], r["mean_T"]))
    command = (f"python benchmarks/ld_sweep.py --tasks {' '.join(args.tasks)} --checkpoints {args.checkpoints} "
               f"--scenes {args.scenes} --seed {args.seed} --w0 {' '.join(map(str, args.w0))} "
               f"--alpha {' '.join(map(str, args.alpha))} --decay {' '.join(map(str, args.decay))}")
    if args.sampler or args.steps:
        command += f" --sampler {args.sampler} --steps {args.steps}"
    write_json(args.out, {"command": command, "scenes_per_set": args.scenes, "seed": args.seed, "min_success": MIN_SUCCESS,
                          "compute_minutes": round((time.perf_counter() - t0) / 60, 1), "rows": rows,
                          "chosen": {k: chosen[k] for k in ("w0", "alpha", "decay")}, "chosen_meets_success": bool(ok)})
    head = "| w0 | alpha | decay | mean T | min success | " + " | ".join(f"{t.name} T | {t.name} T amb | {t.name} D̂ | {t.name} Ê | {t.name} success" for t in tasks) + " |"
    lines = ["# Legibility Diffuser guidance sweep", "",
             f"`{command}`. {args.scenes} ambiguous + {args.scenes} clear validation scenes per task (seed {args.seed}), "
             f"the same noise for every setting. Chosen (**bold**): the best mean T with success >= {MIN_SUCCESS} on every task"
             + ("." if ok else "; no setting reached it, so the most successful one."), "", head, "|" + "---|" * (5 + 5 * len(tasks))]
    for r in sorted(rows, key=lambda r: -r["mean_T"]):
        cells = [r["w0"], r["alpha"], r["decay"], r["mean_T"], r["min_success"]]
        for t in tasks:
            v = r["tasks"][t.name]
            cells += [v["transparency"], v["T_ambiguous"], v["d_hat"], v["e_hat"], v["success"]]
        mark = "**" if r is chosen else ""
        lines.append("| " + " | ".join(f"{mark}{c}{mark}" for c in cells) + " |")
    write_text(args.out.with_suffix(".md"), "\n".join(lines) + "\n")
    print(f"chosen: {chosen['w0'], chosen['alpha'], chosen['decay']} (meets success: {bool(ok)})")


if __name__ == "__main__":
    main()
