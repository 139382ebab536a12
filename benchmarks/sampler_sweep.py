"""Fewer denoising steps at equal quality? One row per (method, sampler, steps) against DDPM-100.

Regenerates: `results/benchmarks/sampler_sweep_*.md`

    python benchmarks/sampler_sweep.py --task navigation --checkpoints results/cpu/navigation/checkpoints \
        [--methods dp scdp ld] [--samplers ddim dpmsolver] [--steps 50 20 10 5] [--scenes 100] [--seed 2] \
        [--out results/benchmarks/sampler_sweep_navigation.json]

Every configuration plans the same ``--scenes`` ambiguous + ``--scenes`` clear random scenes
(validation seed 2 by default, disjoint from the evaluation's seed 1) with the same per-scene
noise. A row holds success, the mean T, D̂ and Ê, each with the paired mean difference to the
same method under DDPM-100 and its 95 % bootstrap interval, and the milliseconds per planned
chunk (the rollouts' wall time over all scenes' chunks, so amortised over the batched scenes;
run it alone on the machine; batch-1 latency is ``benchmarks/plan_latency.py``'s job).
The sampler is swapped at load time: the trained network predicts ε at any step.

The parity rule (issue 10) is judged per (sampler, steps) over every method and both scene
sets: success >= 0.98, and ΔT within ±0.02 of DDPM-100, either strictly (the whole 95 %
interval inside ±0.02) or by its mean only (the interval may be wider than ±0.02 but its mean
is inside and the interval contains 0). The fewest steps that pass are named at the end.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from scdp.config import PlanningOptions
from scdp.data.scenes import VALIDATION
from scdp.evaluation.protocol import evaluate_methods, scene_sets
from scdp.evaluation.statistics import compare
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR, SAMPLERS
from scdp.metrics import MIN_SUCCESS
from scdp.policies.loaders import load_method
from scdp.tasks import get_task

METRICS = (("success", "success"), ("transparency", "T"), ("d_hat", "D"), ("e_hat", "E"))
REFERENCE = ("ddpm", 100)
T_TOLERANCE = 0.02  # the parity rule (with scdp.metrics.MIN_SUCCESS)


def run(task, checkpoints, method, sampler, steps, sets, seed):
    """Records of one configuration, the chunks planned over all scenes, and the wall seconds."""
    planner = load_method(method, checkpoints, task, PlanningOptions(sampler=sampler, steps=steps))
    t0 = time.perf_counter()
    records = evaluate_methods(task, {method: planner}, sets, seed=seed, progress=False)
    return records, sum(len(r.styles) for r in records), time.perf_counter() - t0


def sweep(task, checkpoints, methods, samplers, steps, scenes, seed) -> list[dict]:
    sets = {k: v for k, v in scene_sets(task, scenes, seed, stream=VALIDATION).items() if k in (AMBIGUOUS, CLEAR)}
    rows = []
    for method in methods:
        reference, ref_calls, ref_s = run(task, checkpoints, method, *REFERENCE, sets, seed)
        configs = [REFERENCE] + [(s, k) for s in samplers for k in steps]
        for sampler, k in configs:
            if (sampler, k) == REFERENCE:
                records, calls, seconds = reference, ref_calls, ref_s
            else:
                records, calls, seconds = run(task, checkpoints, method, sampler, k, sets, seed)
            tagged = [replace(r, method="x") for r in records]
            both = tagged + reference
            row = {"task": task.name, "method": method, "sampler": sampler, "steps": k,
                   "ms_per_chunk": round(1000 * seconds / max(calls, 1), 2), "chunks": calls}
            for scene_set in (AMBIGUOUS, CLEAR):
                subset = [r for r in both if r.scene_set == scene_set]
                for metric, short in METRICS:
                    values = [r.success if metric == "success" else r.metrics[metric] for r in records if r.scene_set == scene_set]
                    c = compare(subset, "x", method, metric)
                    row[f"{short}_{scene_set}"] = round(float(np.mean(values)), 3)
                    row[f"d{short}_{scene_set}"] = [round(c.mean, 3), round(c.lo, 3), round(c.hi, 3)]
            rows.append(row)
            print(row, flush=True)
    return rows


def parity(rows: list[dict]) -> list[dict]:
    """Per (sampler, steps): does every method, in both scene sets, keep success and T (see module doc)?"""
    out = []
    for sampler, steps in dict.fromkeys((r["sampler"], r["steps"]) for r in rows):
        group = [r for r in rows if (r["sampler"], r["steps"]) == (sampler, steps)]
        cells = [(r[f"success_{s}"], r[f"dT_{s}"]) for r in group for s in (AMBIGUOUS, CLEAR)]
        success = all(ok >= MIN_SUCCESS for ok, _ in cells)
        strict = success and all(-T_TOLERANCE <= lo and hi <= T_TOLERANCE for _, (_, lo, hi) in cells)
        by_mean = success and all(abs(m) <= T_TOLERANCE and lo <= 0.0 <= hi for _, (m, lo, hi) in cells)
        out.append({"sampler": sampler, "steps": steps, "methods": [r["method"] for r in group],
                    "min_success": round(min(ok for ok, _ in cells), 3),
                    "max_abs_dT": round(max(abs(m) for _, (m, _, _) in cells), 3),
                    "widest_dT_interval": round(max(max(abs(lo), abs(hi)) for _, (_, lo, hi) in cells), 3),
                    "passes_strict": strict, "passes_by_mean": by_mean})
    return out


def fewest(verdicts: list[dict], key: str):
    """The passing (sampler, steps) with the fewest steps (ties: the order swept), or None."""
    passing = [v for v in verdicts if v[key]]
    return min(passing, key=lambda v: v["steps"]) if passing else None


def markdown(rows: list[dict], scenes: int, seed: int) -> str:
    lines = [f"# Sampler sweep: {rows[0]['task']}", "",
             f"{scenes} ambiguous + {scenes} clear random scenes (seed {seed}), the same noise per scene. "
             "Δ = paired difference to the same method under DDPM-100, mean [95 % bootstrap interval]. "
             "`python benchmarks/sampler_sweep.py --help` regenerates it.", ""]
    for scene_set in (AMBIGUOUS, CLEAR):
        lines += [f"## {scene_set} scenes", "",
                  "| method | sampler | steps | ms/chunk | success | T | ΔT | D̂ | ΔD̂ | Ê | ΔÊ |", "|" + "---|" * 11]
        for r in rows:
            cell = lambda v: f"{v[0]:+.3f} [{v[1]:+.3f}, {v[2]:+.3f}]"  # noqa: E731
            lines.append(f"| {r['method']} | {r['sampler']} | {r['steps']} | {r['ms_per_chunk']} | {r[f'success_{scene_set}']} | "
                         f"{r[f'T_{scene_set}']} | {cell(r[f'dT_{scene_set}'])} | {r[f'D_{scene_set}']} | {cell(r[f'dD_{scene_set}'])} | "
                         f"{r[f'E_{scene_set}']} | {cell(r[f'dE_{scene_set}'])} |")
        lines.append("")
    verdicts = parity(rows)
    lines += ["## Parity with DDPM-100", "",
              f"Every method in both scene sets: success >= {MIN_SUCCESS}, and ΔT within ±{T_TOLERANCE} — *strict*: the "
              "whole 95 % interval inside; *by mean*: the mean inside and the interval containing 0.", "",
              "| sampler | steps | min success | max abs ΔT | widest interval end | strict | by mean |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {v['sampler']} | {v['steps']} | {v['min_success']} | {v['max_abs_dT']} | {v['widest_dT_interval']} | "
              f"{'yes' if v['passes_strict'] else 'no'} | {'yes' if v['passes_by_mean'] else 'no'} |" for v in verdicts]
    for key, name in (("passes_strict", "strict"), ("passes_by_mean", "by mean")):
        best = fewest(verdicts, key)
        lines.append(f"\nFewest steps passing ({name}): " + (f"{best['sampler']}-{best['steps']}" if best else "none"))
    lines.append("")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", required=True, help="navigation or block_reach")
    parser.add_argument("--checkpoints", required=True, type=Path, help="folder with base/, ld/, encoder/, style_*/")
    parser.add_argument("--methods", nargs="+", default=["dp", "scdp", "ld"])
    parser.add_argument("--samplers", nargs="+", default=["ddim", "dpmsolver"], choices=SAMPLERS)
    parser.add_argument("--steps", type=int, nargs="+", default=[50, 20, 10, 5])
    parser.add_argument("--scenes", type=int, default=100, help="per scene set (default 100)")
    parser.add_argument("--seed", type=int, default=2, help="scene seed (default 2: validation scenes)")
    parser.add_argument("--out", type=Path, help="JSON output (default results/benchmarks/sampler_sweep_TASK.json)")
    args = parser.parse_args()
    task = get_task(args.task)
    out = args.out or Path(f"results/benchmarks/sampler_sweep_{task.name}.json")
    t0 = time.perf_counter()
    rows = sweep(task, args.checkpoints, args.methods, args.samplers, args.steps, args.scenes, args.seed)
    write_json(out, {"rows": rows, "parity": parity(rows), "scenes_per_set": args.scenes, "seed": args.seed,
                     "checkpoints": str(args.checkpoints),
                     "compute_minutes": round((time.perf_counter() - t0) / 60, 1)})
    write_text(out.with_suffix(".md"), markdown(rows, args.scenes, args.seed))


if __name__ == "__main__":
    main()
