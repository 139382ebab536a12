"""Does ``--runtime onnx`` plan what torch plans? Every planner, 100 + 100 scenes per task.

Regenerates: `results/benchmarks/onnx_parity.md`

    python benchmarks/onnx_parity.py --run results/cpu --out results/benchmarks/onnx_parity

For each task, the cpu reproduction's checkpoints are copied to a temporary folder and exported
(``scdp export``: the denoisers of base/ and ld/). Every planner then rolls out the same
``--scenes`` ambiguous + ``--scenes`` clear scenes of the validation stream (never the evaluation
scenes) with the same seeds, once with torch and once with ONNX Runtime. Reported per task and
planner: the largest |difference| of each metric over the scenes, the largest distance between
the two paths, and whether every run's success and every chunk's style agree. The criterion is
1e-4 on every metric. Writes ``OUT.json`` and ``OUT.md``; run it with nothing else on the machine.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from scdp.cli import main as scdp_main
from scdp.config import PlanningOptions
from scdp.data.scenes import VALIDATION
from scdp.evaluation.protocol import evaluate_methods, scene_sets
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.policies.loaders import load_method
from scdp.tasks import get_task

PLANNERS = ("dp", "ld", "ld_paper", "scdp", "scdp_blend", "scdp_legible", "scdp_efficient", "scdp_paper")
METRICS = ("d_hat", "e_hat", "transparency", "legibility", "detachment", "efficiency")
CRITERION = 1e-4


def compare(torch_records, onnx_records) -> dict:
    pairs = list(zip(torch_records, onnx_records))
    assert all((a.scene_set, a.scene_index, a.method) == (b.scene_set, b.scene_index, b.method) for a, b in pairs)
    gaps = {m: max(abs(a.metrics[m] - b.metrics[m]) for a, b in pairs) for m in METRICS}
    path, same = 0.0, []
    for a, b in pairs:
        pa, pb = np.asarray(a.path), np.asarray(b.path)
        n = min(len(pa), len(pb))
        path = max(path, float(np.abs(pa[:n] - pb[:n]).max()), 0.0 if len(pa) == len(pb) else float("inf"))
        same.append(len(pa) == len(pb) and bool(np.array_equal(pa, pb)))
    # stored paths are rounded to 0.1 mm before scoring: where the two stored paths are identical the metrics
    # are too, so every metric gap comes from a waypoint whose rounding flipped by one step
    same_gap = max((abs(a.metrics[m] - b.metrics[m]) for (a, b), s in zip(pairs, same) if s for m in METRICS), default=0.0)
    return {"runs": len(pairs), "max_metric_gap": gaps, "max_path_gap": path,
            "identical_stored_paths": round(sum(same) / len(same), 3), "max_metric_gap_identical_paths": same_gap,
            "success_agrees": all(a.success == b.success for a, b in pairs),
            "styles_agree": all(a.styles == b.styles for a, b in pairs),
            "within_criterion": max(gaps.values()) <= CRITERION}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", default="results/cpu")
    p.add_argument("--out", default="results/benchmarks/onnx_parity")
    p.add_argument("--scenes", type=int, default=100, help="scenes per set (ambiguous, clear; default 100)")
    p.add_argument("--seed", type=int, default=0, help="seed of the validation scenes (default 0)")
    p.add_argument("--tasks", nargs="+", default=["block_reach", "navigation"])
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="scdp-parity-"))
    result = {"command": " ".join(["python", "benchmarks/onnx_parity.py", *(argv or sys.argv[1:])]), "criterion": CRITERION,
              "scenes_per_set": args.scenes, "tasks": {}}
    for name in args.tasks:
        task = get_task(name)
        ckpt = work / name
        shutil.copytree(Path(args.run) / name / "checkpoints", ckpt)
        assert scdp_main(["export", "--task", name, str(ckpt)]) == 0
        sets = {k: v for k, v in scene_sets(task, args.scenes, args.seed, stream=VALIDATION).items() if k in (AMBIGUOUS, CLEAR)}
        records, seconds = {}, {}
        for runtime in ("torch", "onnx"):
            planners = {m: load_method(m, ckpt, task, PlanningOptions(runtime=runtime)) for m in PLANNERS}
            start = time.perf_counter()
            records[runtime] = evaluate_methods(task, planners, sets, seed=args.seed)
            seconds[runtime] = round(time.perf_counter() - start, 1)
        result["tasks"][name] = {"wall_s": seconds, "planners": {
            m: compare([r for r in records["torch"] if r.method == m], [r for r in records["onnx"] if r.method == m])
            for m in PLANNERS}}
        print(f"[{name}] {seconds}", flush=True)
    shutil.rmtree(work, ignore_errors=True)
    result["compute_minutes"] = round((time.perf_counter() - t0) / 60, 1)
    result["all_within_criterion"] = all(v["within_criterion"] and v["success_agrees"] and v["styles_agree"]
                                         for t in result["tasks"].values() for v in t["planners"].values())
    out = Path(args.out)
    write_json(out.with_suffix(".json"), result)
    write_text(out.with_suffix(".md"), markdown(result))
    print(markdown(result))
    return 0


def markdown(r: dict) -> str:
    lines = ["# ONNX Runtime against torch: the same plans", "",
             f"`{r['command']}` ({r['compute_minutes']} min). Every planner on {r['scenes_per_set']} ambiguous + "
             f"{r['scenes_per_set']} clear validation scenes per task, same seeds, denoiser in torch vs ONNX Runtime. "
             f"Criterion: every metric within {r['criterion']:g}. All within it, with success and every chunk's style "
             f"agreeing: **{'yes' if r['all_within_criterion'] else 'no'}**.", "",
             "| task | planner | runs | " + " | ".join(f"max Δ {m}" for m in METRICS)
             + " | max path Δ | identical stored paths | success agrees | styles agree |",
             "|---|---|---|" + "---|" * (len(METRICS) + 4)]
    for task, t in r["tasks"].items():
        for m, v in t["planners"].items():
            lines.append(f"| {task} | {m} | {v['runs']} | " + " | ".join(f"{v['max_metric_gap'][k]:.1e}" for k in METRICS)
                         + f" | {v['max_path_gap']:.1e} | {v['identical_stored_paths']:.0%} | {'yes' if v['success_agrees'] else 'no'} | "
                           f"{'yes' if v['styles_agree'] else 'no'} |")
    lines += ["", "Stored paths are rounded to 0.1 mm (0.1 mrad) before they are scored. Where the two stored paths are "
              "identical, the largest metric gap is "
              + f"{max(v['max_metric_gap_identical_paths'] for t in r['tasks'].values() for v in t['planners'].values()):.1e}: "
              "every other gap comes from a waypoint whose rounding flipped by one step.",
              "", "Rollout wall seconds (torch / onnx, all planners, simulation included): "
              + ", ".join(f"{t}: {v['wall_s']['torch']} / {v['wall_s']['onnx']}" for t, v in r["tasks"].items()), ""]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
