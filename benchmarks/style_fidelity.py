"""Style fidelity of few-step planners (issue 79): does a planner that makes fewer network calls keep SCDP's styles?

Regenerates: `results/benchmarks/style_fidelity.md`, `results/benchmarks/style_fidelity_step256.md`

    python benchmarks/style_fidelity.py --run results/cpu --out results/benchmarks/style_fidelity

(``style_fidelity_step256``: the same command, ``--out`` renamed, with the student trained by
``scdp train student --set student.step_weight=256`` in ``<task>/checkpoints/student``: the step-term
ablation of issue 79; its weights are not kept.)

For each task, on ``--scenes`` ambiguous + ``--scenes`` clear validation scenes (seed ``--seed``; no
gate and no choice has used seed 79), the forced styles (``scdp_legible``, ``scdp_efficient``) are
planned by the full sampler (the checkpoints' own, DDPM-20 cold) and by each candidate below, from the
same start states with the same noise streams. :mod:`scdp.evaluation.fidelity` measures each candidate
against the full sampler: the distance between their paths, the forced-style D̂ gap and the path-length
observer's gap at half the motion, paired by scene with 95 % intervals, and its rule (keeps ≥ 90 % of
the D̂ gap; observer-gap lower bound above −0.08).

Candidates without training: the real-time default (DDPM-8 warm-started at step 4: 4 network calls per
warm chunk), DDPM-8 warm-started at step 6 (2 calls), DDIM-4 warm-started at step 2 (2 calls), DDIM-2
warm-started at step 1 (1 call), DDIM-2 cold on the base (2 calls: the student's sampler without its
training). One trained: the few-step student (``scdp_student``, :mod:`scdp.training.distill`: DDIM-2
cold, 2 calls per chunk), read from ``<task>/checkpoints/student`` (``scdp train student``).
Two arms check the measure itself: the full sampler with its noise
redrawn (must keep the style; its path distance is the floor that sampler noise alone reaches) and
the real-time default with its films off (must fail). Each candidate's network calls per Navigation
trajectory at batch 1 are counted (the time per call is ``responsive.md``'s).
Nothing here changes a default: a candidate becomes one only through a pre-registered gate.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

import numpy as np
from realtime import matmul_gflops  # sibling benchmarks
from realtime_gate import DEFAULT, plan

from scdp.config import PlanningOptions
from scdp.data.scenes import BENCHMARK, VALIDATION, sample_scenes
from scdp.evaluation.fidelity import EFFICIENT, LEGIBLE, fidelity
from scdp.evaluation.protocol import scene_sets
from scdp.evaluation.rollout import rollout
from scdp.evaluation.statistics import PairedDifference
from scdp.io import write_report
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.policies.loaders import load_method
from scdp.tasks import get_task

SEED = 79


class Candidate(NamedTuple):
    """A planner measured against the full sampler: its options, whether its films are on, and the SCDP
    planner it runs (``scdp`` on the base, or ``scdp_student`` on the distilled student)."""

    planning: PlanningOptions
    films: bool = True
    method: str = "scdp"


STUDENT = "scdp_student"
CANDIDATES = {
    "null: the full sampler, noise redrawn": Candidate(DEFAULT),
    "real-time default: DDPM-8, warm from step 4": Candidate(PlanningOptions(sampler="ddpm", steps=8, warm_skip=4)),
    "DDPM-8, warm from step 6": Candidate(PlanningOptions(sampler="ddpm", steps=8, warm_skip=6)),
    "DDIM-4, warm from step 2": Candidate(PlanningOptions(sampler="ddim", steps=4, warm_skip=2)),
    "DDIM-2, warm from step 1": Candidate(PlanningOptions(sampler="ddim", steps=2, warm_skip=1)),
    "DDIM-2 cold, the base (the student's sampler, untrained)": Candidate(PlanningOptions(sampler="ddim", steps=2)),
    "student: DDIM-2 cold, distilled (scdp_student)": Candidate(PlanningOptions(), method=STUDENT),
    "real-time default, films off (must fail)": Candidate(PlanningOptions(sampler="ddpm", steps=8, warm_skip=4), films=False),
}


def styled_records(task, checkpoints, candidate: Candidate, sets, *, noise: str = "") -> list:
    """Records of both forced styles under one planner (``noise``: another sampler-noise stream), named
    ``scdp_legible`` and ``scdp_efficient`` whichever SCDP planner made them."""
    records = []
    for style in (LEGIBLE, EFFICIENT):
        method = style if candidate.method == "scdp" else f"{candidate.method}:{style.removeprefix('scdp_')}"
        runs = plan(task, checkpoints, method, candidate.planning, sets, noise=noise, films=candidate.films, seed=SEED)
        records += [replace(r, method=style) for r in runs]
    return records


def network_calls(task, checkpoints, candidate: Candidate, scenes: int = 20) -> float:
    """Network calls per trajectory (p50), SCDP at batch 1 as a service plans one: deterministic, so no clock."""
    planning = candidate.planning
    planner = load_method(candidate.method, checkpoints, task, PlanningOptions.of_entry(
        "plan", sampler=planning.sampler, steps=planning.steps, warm_skip=planning.warm_skip or 0))  # cold unless warm
    pairs = [(goals, target) for goals, target in sample_scenes(task, scenes, 0, stream=BENCHMARK)]
    calls = []
    unet = planner.base.unet
    forward = unet.forward

    def counted(*args, **kwargs):
        calls[-1] += 1
        return forward(*args, **kwargs)

    unet.forward = counted
    for i, scene in enumerate(pairs):
        calls.append(0)
        rollout(task, planner, [scene], seeds=[i])
    unet.forward = forward
    return float(np.median(calls))


def cell(row: dict) -> str:
    d = PairedDifference.from_row(row)
    return f"{d.cell()}{'*' if d.holds('>') or d.holds('<') else ''}"


def markdown(result: dict) -> str:
    lines = ["# Style fidelity of few-step planners (issue 79)", "",
             f"`{result['command']}` ({result['minutes']:.1f} compute-min; {result['gflops']:.0f} GFLOP/s fp32 matmul, "
             f"2 cores). {result['scenes']} ambiguous + {result['scenes']} clear validation scenes per task, seed {SEED}; "
             "every candidate against the full sampler (the checkpoints' DDPM-20, cold) on the same scenes and noise "
             "streams. Path distance: mean distance (m) between the two paths of one forced style, resampled by arc "
             "length, over both scene sets and styles. D̂ gap and observer gap: (legible − efficient) under the "
             "candidate minus under the full sampler, ambiguous scenes; 95 % scene-bootstrap intervals, * excludes "
             "zero. Keeps the style: ≥ 90 % of the full sampler's D̂ gap and the observer-gap lower bound above "
             "−0.08 (`scdp.evaluation.fidelity`); the null arm must keep it and the films-off arm must not: where "
             "the null arm fails it, the rule cannot tell candidates apart at this N, and only the pre-registered "
             "gate (800 + 800 scenes, one-sided bounds) decides a default. Calls: network calls per Navigation "
             "trajectory, scdp at batch 1 as `scdp plan` plans it, 20 scenes (p50); the time each call takes is "
             "in `responsive.md`.", ""]
    for task, rows in result["tasks"].items():
        lines += [f"## {task}", "", "| candidate | path distance (m) | D̂ gap, candidate − full | share of the D̂ gap | "
                  "observer gap, candidate − full | keeps the style (rule) | calls |", "|---|---|---|---|---|---|---|"]
        for label, r in rows.items():
            calls = result["calls"].get(label)
            lines.append(f"| {label} | {cell(r['path_distance'])} | {cell(r['d_hat_gap'])} | {r['gap_share']:.2f} | "
                         f"{cell(r['observer_gap'])} | {'yes' if r['keeps_style'] else '**no**'} | "
                         f"{'–' if calls is None else f'{calls:.0f}'} |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", type=Path, default=Path("results/cpu"), help="a reproduction whose <task>/checkpoints to use")
    p.add_argument("--scenes", type=int, default=100, help="ambiguous and clear validation scenes each, per task")
    p.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    p.add_argument("--out", type=Path, default=Path("results/benchmarks/style_fidelity"))
    args = p.parse_args(argv)
    started, gflops = time.perf_counter(), matmul_gflops()
    result = {"command": "python benchmarks/style_fidelity.py " + " ".join(argv if argv is not None else sys.argv[1:]),
              "scenes": args.scenes, "seed": SEED, "gflops": gflops, "tasks": {}, "calls": {}}
    for name in args.tasks:
        task = get_task(name)
        checkpoints = args.run / name / "checkpoints"
        sets = {k: v for k, v in scene_sets(task, args.scenes, SEED, stream=VALIDATION).items() if k in (AMBIGUOUS, CLEAR)}
        full = styled_records(task, checkpoints, Candidate(DEFAULT), sets)
        result["tasks"][name] = {}
        for label, candidate in CANDIDATES.items():
            noise = "redrawn" if candidate.planning is DEFAULT else ""
            result["tasks"][name][label] = fidelity(full, styled_records(task, checkpoints, candidate, sets, noise=noise))
    navigation = get_task("navigation")
    for label, candidate in CANDIDATES.items():
        if candidate.films and candidate.planning is not DEFAULT:
            result["calls"][label] = network_calls(navigation, args.run / "navigation" / "checkpoints", candidate)
    result["minutes"] = (time.perf_counter() - started) / 60
    text = markdown(result)
    write_report(args.out.with_suffix(".md"), text, result)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
