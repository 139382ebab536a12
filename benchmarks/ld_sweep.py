"""Tune Legibility Diffuser's guidance on validation scenes: maximise mean T subject to success >= 0.98.

    python benchmarks/ld_sweep.py --task navigation --checkpoints DIR [--scenes 20] [--seed 2]
        [--w0 1 2.5 5 10 20] [--alpha 0.5 0.9 1] [--decay 0.5 0.75 1] [--sampler ddim --steps 10]
        [--out results/cpu/ld_sweep_<task>.json]

The scenes (``--scenes`` ambiguous + ``--scenes`` clear, seed 2) are disjoint from the
evaluation scenes (seed 1). Every setting runs on the same scenes with the same noise. The
output lists every setting's mean T, D̂, Ê and success, and the chosen one (the best mean T
among the settings that reach success >= 0.98, else the most successful).
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
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.policies.loaders import load_ld
from scdp.tasks import get_task

MIN_SUCCESS = 0.98


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", required=True)
    parser.add_argument("--checkpoints", required=True, type=Path)
    parser.add_argument("--scenes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=2)
    parser.add_argument("--w0", type=float, nargs="+", default=[1.0, 2.5, 5.0, 10.0, 20.0])
    parser.add_argument("--alpha", type=float, nargs="+", default=[0.5, 0.9, 1.0])
    parser.add_argument("--decay", type=float, nargs="+", default=[0.5, 0.75, 1.0])
    parser.add_argument("--sampler", choices=["ddpm", "ddim", "dpmsolver"], help="replace the checkpoint's sampler")
    parser.add_argument("--steps", type=int, help="denoising steps of that sampler")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    task = get_task(args.task)
    out = args.out or Path(f"results/cpu/ld_sweep_{task.name}.json")
    sets = {k: v for k, v in scene_sets(task, args.scenes, args.seed).items() if k in (AMBIGUOUS, CLEAR)}
    t0 = time.perf_counter()
    rows = []
    for w0, alpha, decay in itertools.product(args.w0, args.alpha, args.decay):
        guidance = GuidanceConfig(w0=w0, alpha=alpha, decay=decay)
        records = evaluate_methods(task, {"ld": load_ld(args.checkpoints / "ld", task, guidance, args.sampler, args.steps)}, sets, seed=args.seed,
                                   progress=False)
        row = {"w0": w0, "alpha": alpha, "decay": decay,
               **{k: round(float(np.mean([r.metrics[k] for r in records])), 4) for k in ("transparency", "d_hat", "e_hat")},
               "success": round(float(np.mean([r.success for r in records])), 4)}
        print(json.dumps(row), flush=True)
        rows.append(row)
    ok = [r for r in rows if r["success"] >= MIN_SUCCESS]
    chosen = max(ok, key=lambda r: r["transparency"]) if ok else max(rows, key=lambda r: (r["success"], r["transparency"]))
    command = f"python benchmarks/ld_sweep.py --task {task.name} --checkpoints {args.checkpoints} --scenes {args.scenes}"
    if args.sampler or args.steps:
        command += f" --sampler {args.sampler} --steps {args.steps}"
    write_json(out, {"command": command,
                     "scenes_per_set": args.scenes, "seed": args.seed, "min_success": MIN_SUCCESS,
                     "compute_minutes": round((time.perf_counter() - t0) / 60, 1), "rows": rows,
                     "chosen": {k: chosen[k] for k in ("w0", "alpha", "decay")}, "chosen_meets_success": bool(ok)})
    lines = [f"# Legibility Diffuser guidance sweep: {task.name}", "",
             f"`{command}`. {args.scenes} ambiguous + {args.scenes} clear validation scenes (seed {args.seed}), "
             f"the same noise for every setting. Chosen (**bold**): the best mean T with success >= {MIN_SUCCESS}"
             + ("." if ok else "; no setting reached it, so the most successful one."), "",
             "| w0 | alpha | decay | T | D̂ | Ê | success |", "|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: -r["transparency"]):
        cells = [r["w0"], r["alpha"], r["decay"], r["transparency"], r["d_hat"], r["e_hat"], r["success"]]
        mark = "**" if r is chosen else ""
        lines.append("| " + " | ".join(f"{mark}{c}{mark}" for c in cells) + " |")
    write_text(out.with_suffix(".md"), "\n".join(lines) + "\n")
    print(f"chosen: {chosen}")


if __name__ == "__main__":
    main()
