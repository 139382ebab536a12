"""Does a planner ask the robot for more than it can do in one step? The few-step student against its teacher.

Regenerates: `results/benchmarks/student_reach.md`, `results/benchmarks/student_reach_step256.md`

    python benchmarks/student_reach.py --run results/cpu --out results/benchmarks/student_reach

(``student_reach_step256``: the same command, ``--out`` renamed, with the student trained by
``scdp train student --set student.step_weight=256`` in ``<task>/checkpoints/student``: the step-term
ablation of issue 79; its weights are not kept.)

The safe service (``scdp serve``) refuses a chunk any of whose actions asks for more than
:data:`scdp.tasks.base.REACH_MARGIN` times the robot's one-step reach (``Task.reach_used``: the
commanded next state against what the datasheet speed limits allow in one control period). For each
task, ``--scenes`` benchmark scenes are rolled out by SCDP under four planners (the few-step student,
the base with the student's sampler untrained, the student's teacher, and the trained sampler), and
each rollout's largest reach ratio is read from its commanded actions. Deterministic: no clock.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from scdp.config import PlanningOptions
from scdp.data.scenes import BENCHMARK, sample_scenes
from scdp.evaluation.rollout import rollout
from scdp.io import write_report
from scdp.policies.loaders import load_method
from scdp.tasks import get_task
from scdp.tasks.base import REACH_MARGIN

PLANNERS = {  # label: (method, planning options)
    "student (scdp_student: DDIM-2, distilled)": ("scdp_student", PlanningOptions()),
    "the base at DDIM-2 (the student's sampler, untrained)": ("scdp", PlanningOptions(sampler="ddim", steps=2)),
    "the base at DDIM-20 (the student's teacher)": ("scdp", PlanningOptions(sampler="ddim", steps=20)),
    "the trained sampler (DDPM-20)": ("scdp", PlanningOptions()),
}


def reach_shares(task, run) -> np.ndarray:
    """(T,) the share of the one-step reach each commanded action of ``run`` asks for."""
    states, actions = np.asarray(run.states), np.asarray(run.actions)
    if not len(actions):
        return np.zeros(0)
    before = np.vstack([states[:1], actions[:-1]])  # the state each command starts from, as commanded
    return np.asarray(task.reach_used(before, actions))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", type=Path, default=Path("results/cpu"), help="a reproduction whose <task>/checkpoints hold a student")
    p.add_argument("--scenes", type=int, default=40, help="benchmark scenes per task")
    p.add_argument("--out", type=Path, default=Path("results/benchmarks/student_reach"))
    args = p.parse_args(argv)
    started = time.perf_counter()
    result = {"command": "python benchmarks/student_reach.py " + " ".join(argv if argv is not None else sys.argv[1:]),
              "scenes": args.scenes, "margin": REACH_MARGIN, "tasks": {}}
    for name in ("navigation", "block_reach"):
        task = get_task(name)
        scenes = list(sample_scenes(task, args.scenes, 0, stream=BENCHMARK))
        result["tasks"][name] = {}
        for label, (method, planning) in PLANNERS.items():
            planner = load_method(method, args.run / name / "checkpoints", task, planning)
            shares = [reach_shares(task, r) for r in rollout(task, planner, scenes, seeds=list(range(len(scenes))))]
            over = [np.nonzero(s > REACH_MARGIN)[0] for s in shares]  # the steps past the margin, per rollout
            result["tasks"][name][label] = {
                "over": sum(len(o) > 0 for o in over), "max": max(float(s.max(initial=0.0)) for s in shares),
                "steps_over": sum(len(o) for o in over),
                "at_chunk_start": sum(int(np.sum(o % planner.n_action_steps == 0)) for o in over)}
    result["minutes"] = (time.perf_counter() - started) / 60
    lines = ["# Does the few-step student ask for more than one step's reach?", "",
             f"`{result['command']}` ({result['minutes']:.1f} compute-min). {args.scenes} benchmark scenes per task, SCDP "
             f"(auto style). Counted: the rollouts one of whose commanded actions asks for more than "
             f"{REACH_MARGIN:g}× the robot's one-step reach (a chunk the safe service refuses to send).", "",
             "Steps past it: how many commanded actions, and how many of those are a chunk's first action (the "
             "step from where the last chunk left the robot to where the new one starts).", "",
             f"| task | planner | rollouts with a step beyond {REACH_MARGIN:g}× | largest share of the reach | steps past "
             "it (at a chunk's first action) |", "|---|---|---|---|---|"]
    lines += [f"| {task} | {label} | {row['over']} / {args.scenes} | {row['max']:.2f} | {row['steps_over']} "
              f"({row['at_chunk_start']}) |"
              for task, rows in result["tasks"].items() for label, row in rows.items()]
    text = "\n".join(lines) + "\n"
    write_report(args.out.with_suffix(".md"), text, result)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
