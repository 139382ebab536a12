"""Tune Legibility Diffuser's guidance on validation scenes with the rule of scdp.evaluation.selection.

Regenerates: `results/cpu/ld_sweep.md`

    python benchmarks/ld_sweep.py --tasks navigation block_reach --checkpoints results/cpu [--scenes 100] [--seed 2]
        [--w0 0.5 1 2 4.5] [--alpha 0.5 0.9] [--decay 0.5 0.8] [--window 1 0.7 0.4] [--sampler ddpm --steps 20]
        [--out results/cpu/ld_sweep.json]

``--checkpoints`` is a reproduction folder (``<task>/checkpoints/ld`` inside it). The scenes
(``--scenes`` ambiguous + ``--scenes`` clear per task) come from the validation stream
(:data:`scdp.data.scenes.VALIDATION`), which never shares a scene with the evaluation stream.
Every setting runs on the same scenes with the same noise. The grid is w0 × alpha × decay ×
window (the noisiest fraction of the denoising steps that is guided), plus one unguided row
(w0 = 0): LD's goal-dropout base on its own, the floor every guided setting starts from, beside
DP's base on the same scenes. One
guidance serves every task (a preset has one); the rule (:func:`scdp.evaluation.selection.choose`)
picks the best mean failure-aware T among settings with success >= 0.98 in every task and scene
set. The JSON lists every setting; the Markdown table beside it shows them best first.
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from pathlib import Path

import numpy as np

from scdp.cli.parser_common import executor_args
from scdp.config import GuidanceConfig, PlanningOptions
from scdp.data.scenes import VALIDATION
from scdp.evaluation.protocol import evaluate_methods, scene_sets
from scdp.evaluation.selection import MIN_SUCCESS, choose
from scdp.evaluation.statistics import metric_of
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR, SAMPLERS, TASK_NAMES
from scdp.pipeline.executor import Unit, make_executor
from scdp.policies.loaders import load_diffusion, load_ld
from scdp.tasks import get_task

METRICS = ("transparency", "transparency_fa", "d_hat", "e_hat", "success")
SETS = (AMBIGUOUS, CLEAR)


def score(task, folder, guidance, sets, seed, sampler, steps) -> dict:
    """Mean of each metric per scene set for one guidance on one task (``guidance=None``: DP's base)."""
    checkpoints = folder / task.name / "checkpoints"
    planning = PlanningOptions(sampler=sampler, steps=steps)
    planner = (load_diffusion(checkpoints / "base", task, planning=planning) if guidance is None
               else load_ld(checkpoints / "ld", task, guidance, planning))
    records = evaluate_methods(task, {"ld": planner}, sets, seed=seed, progress=False)
    return {s: {m: round(float(np.mean([metric_of(m)(r) for r in records if r.scene_set == s])), 4) for m in METRICS}
            for s in SETS}


def score_unit(task: str, folder: Path, guidance, scenes: int, seed: int, sampler, steps, *, report) -> dict:
    """:func:`score` as a unit of work (scdp.pipeline.executor): one setting on one task's validation scenes."""
    t = get_task(task)
    sets = {k: v for k, v in scene_sets(t, scenes, seed, stream=VALIDATION).items() if k in SETS}
    scored = score(t, folder, guidance, sets, seed, sampler, steps)
    report(1)
    return scored


def grid(args) -> list[GuidanceConfig]:
    """The unguided row, then every guided setting of the grid."""
    rows = [GuidanceConfig(w0=0.0)]
    rows += [GuidanceConfig(w0=w0, alpha=a, decay=d, window=win)
             for w0, a, d, win in itertools.product(args.w0, args.alpha, args.decay, args.window) if w0 > 0]
    return rows


def markdown(command: str, args, tasks, rows: list[dict], chosen: dict, ok: bool, minutes: float, dp: dict) -> str:
    cols = [f"{t.name} {s} {m}" for t in tasks for s in SETS for m in ("T", "T_fa", "D̂", "Ê", "success")]
    head = "| w0 | alpha | decay | window | mean T_fa | min success | " + " | ".join(cols) + " |"
    lines = ["# Legibility Diffuser guidance sweep (validation scenes)", "",
             f"`{command}` ({minutes} compute-min on 2 cores). {args.scenes} ambiguous + {args.scenes} clear scenes per "
             f"task from the validation stream (seed {args.seed}), the same noise for every setting. w0 = 0 is LD's base "
             f"unguided. Rule (`scdp.evaluation.selection`): the best mean failure-aware T (T_fa) over tasks and both "
             f"scene sets among settings with success >= {MIN_SUCCESS} in every task and set"
             + ("; chosen in **bold**." if ok else "; no setting reached it, so the most successful one (**bold**)."),
             "", "## LD's base unguided (w0 = 0) against DP's base, same scenes and noise", "",
             "| task | scene set | DP success | LD base success | DP T_fa | LD base T_fa |", "|---|---|---|---|---|---|"]
    unguided = next(r for r in rows if r["w0"] == 0)["tasks"]
    lines += [f"| {t.name} | {s} | {dp[t.name][s]['success']} | {unguided[t.name][s]['success']} | "
              f"{dp[t.name][s]['transparency_fa']} | {unguided[t.name][s]['transparency_fa']} |" for t in tasks for s in SETS]
    lines += ["", "## Every setting, best first", "", head, "|" + "---|" * (6 + len(cols))]
    for r in sorted(rows, key=lambda r: -r["mean_T_fa"]):
        cells = [r["w0"], r["alpha"], r["decay"], r["window"], r["mean_T_fa"], r["min_success"]]
        cells += [r["tasks"][t.name][s][m] for t in tasks for s in SETS
                  for m in ("transparency", "transparency_fa", "d_hat", "e_hat", "success")]
        mark = "**" if r is chosen else ""
        lines.append("| " + " | ".join(f"{mark}{c}{mark}" for c in cells) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=list(TASK_NAMES), choices=list(TASK_NAMES))
    parser.add_argument("--checkpoints", required=True, type=Path, help="reproduction folder with <task>/checkpoints/ld")
    parser.add_argument("--scenes", type=int, default=100, help="per scene set and task (default 100)")
    parser.add_argument("--seed", type=int, default=2, help="seed of the validation stream (default 2)")
    parser.add_argument("--w0", type=float, nargs="+", default=[0.5, 1.0, 2.0, 4.5])
    parser.add_argument("--alpha", type=float, nargs="+", default=[0.5, 0.9])
    parser.add_argument("--decay", type=float, nargs="+", default=[0.5, 0.8])
    parser.add_argument("--window", type=float, nargs="+", default=[1.0, 0.7, 0.4])
    parser.add_argument("--sampler", choices=SAMPLERS, help="replace the checkpoint's sampler")
    parser.add_argument("--steps", type=int, help="denoising steps of that sampler")
    parser.add_argument("--out", type=Path, default=Path("results/cpu/ld_sweep.json"))
    parser.add_argument("--extend", action="store_true",
                        help="add the grid's new settings to the rows already in --out (same scenes; e.g. past a "
                             "grid edge where the first sweep's best setting lay) and choose over all of them")
    executor_args(parser, "every setting on every task")
    args = parser.parse_args()
    tasks = [get_task(t) for t in args.tasks]
    executor = make_executor(args.executor, address=args.ray_address, workers=args.workers)
    t0 = time.perf_counter()
    previous = json.loads(args.out.read_text()) if args.extend else None
    if previous and (previous["scenes_per_set"], previous["seed"]) != (args.scenes, args.seed):
        parser.error(f"--extend: {args.out} was swept on other scenes")
    if previous:
        rows, minutes_before, commands = previous["rows"], previous["compute_minutes"], previous["commands"]
    else:
        rows, minutes_before, commands = [], 0.0, []
    done = {tuple(r[k] for k in ("w0", "alpha", "decay", "window")) for r in rows}
    todo = [g for g in grid(args) if tuple(getattr(g, k) for k in ("w0", "alpha", "decay", "window")) not in done]
    jobs = ([] if previous else [None]) + todo  # None: DP's base on the same scenes
    label = lambda g: "dp" if g is None else f"w0 {g.w0} alpha {g.alpha} decay {g.decay} window {g.window}"  # noqa: E731
    scored = executor.run([Unit(f"{t.name} {label(g)}", score_unit, (t.name, args.checkpoints, g, args.scenes, args.seed,
                                                                     args.sampler, args.steps)) for g in jobs for t in tasks])
    by_job = {(label(g), t.name): v for (g, t), v in zip([(g, t) for g in jobs for t in tasks], scored)}
    dp = previous["dp"] if previous else {t.name: by_job["dp", t.name] for t in tasks}
    for guidance in todo:
        per_task = {t.name: by_job[label(guidance), t.name] for t in tasks}
        cells = [v[s] for v in per_task.values() for s in SETS]
        row = {**{k: getattr(guidance, k) for k in ("w0", "alpha", "decay", "window")}, "tasks": per_task,
               "mean_T_fa": round(float(np.mean([c["transparency_fa"] for c in cells])), 4),
               "min_success": min(c["success"] for c in cells)}
        print(json.dumps(row), flush=True)
        rows.append(row)
    chosen, ok = choose([r for r in rows if r["w0"] > 0])
    minutes = round(minutes_before + (time.perf_counter() - t0) / 60, 1)
    command = (f"python benchmarks/ld_sweep.py --tasks {' '.join(args.tasks)} --checkpoints {args.checkpoints} "
               f"--scenes {args.scenes} --seed {args.seed} --w0 {' '.join(map(str, args.w0))} "
               f"--alpha {' '.join(map(str, args.alpha))} --decay {' '.join(map(str, args.decay))} "
               f"--window {' '.join(map(str, args.window))}")
    if args.sampler or args.steps:
        command += f" --sampler {args.sampler} --steps {args.steps}"
    commands = commands + [command + (" --extend" if previous else "")]
    command = "`, then `".join(commands)
    write_json(args.out, {"commands": commands, "command": command, "scenes_per_set": args.scenes, "seed": args.seed, "stream": VALIDATION,
                          "min_success": MIN_SUCCESS, "compute_minutes": minutes, "executor": executor.describe(), "rows": rows,
                          "dp": dp, "unguided": next(r for r in rows if r["w0"] == 0)["tasks"],
                          "chosen": {k: chosen[k] for k in ("w0", "alpha", "decay", "window")},
                          "chosen_meets_success": ok})
    write_text(args.out.with_suffix(".md"), markdown(command, args, tasks, rows, chosen, ok, minutes, dp))
    print(f"chosen: w0 {chosen['w0']} alpha {chosen['alpha']} decay {chosen['decay']} window {chosen['window']} "
          f"(meets success: {ok})")


if __name__ == "__main__":
    main()
