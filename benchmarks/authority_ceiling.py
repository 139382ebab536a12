"""What the demonstrations themselves allow a mid-motion switch to do (issue 76): the style-authority table of
``benchmarks/style_authority.py`` measured on demo curves picked by their style's own score, no network at all.

Regenerates: `results/authority/ceiling.md`, `results/authority/ceiling.json`

    python benchmarks/authority_ceiling.py

A style predictor learns what "legible" and "efficient" look like from the Bézier demonstrations
(:mod:`scdp.data.bezier`); the best it can do at a switch is follow the best demo-shaped continuation. Per
ambiguous validation scene (the same scenes, seeds and starts as ``style_authority.py``), ``--curves`` demo
control points are drawn (``Task.sample_control_point``):

* the *efficient* path: the straightest of the curves (:func:`scdp.metrics.efficiency`), the *legible* one: the
  most legible (:func:`scdp.metrics.legibility`, eq. 2);
* a switch at fraction f of the held path: the held curve up to the point it reaches after ``round(f N)``
  steps, then the best of ``--curves`` fresh demo curves from that point to the goal, scored as the predictors'
  rest windows are (:func:`scdp.scoring.rest.rest_score`); at f = 0 the path picked from the start.

Two joins: ``smooth`` blends into the fresh curve as the turning demos do
(:func:`scdp.data.bezier.turning_curve` from the point), what a predictor trained on them could imitate;
``kink`` jumps onto it (no robot with momentum does; the fresh curve alone, for comparison). Separation, observer gain and detour as
:mod:`scdp.evaluation.authority` defines them.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from style_authority import scene_args

from scdp import metrics
from scdp.data.bezier import bezier, curve_by_arc_length, parameter_at_length, turning_curve
from scdp.data.scenes import VALIDATION, scene_seed
from scdp.evaluation.authority import DIRECTIONS, SWITCH_FRACTIONS, summarise, switch_record, table_lines
from scdp.evaluation.dynamic import LEGIBLE
from scdp.evaluation.protocol import scene_sets
from scdp.io import write_report
from scdp.keys import AMBIGUOUS
from scdp.scoring.rest import rest_score
from scdp.scoring.score import cut_at_goal
from scdp.tasks import Task, get_task

JOINS = ("smooth", "kink")


def style_score(task: Task, path: np.ndarray, goals, target: int, style: str) -> float:
    """How ``path`` scores for ``style`` over the whole motion (legibility, eq. 2, or efficiency)."""
    cut = cut_at_goal(task, path, goals, target)
    return metrics.legibility(cut, goals, target) if style == LEGIBLE else metrics.efficiency(cut)


def switched(task: Task, held, controls: np.ndarray, at: int, goals, target: int, style: str, join: str) -> np.ndarray:
    """The demo curve through control point ``held`` up to the point it reaches after ``at`` steps, then the best
    for ``style`` of the curves from there through each of ``controls`` (n, d), joined by ``join``."""
    start, goal = task.start_point, np.asarray(goals, dtype=np.float64)[target]
    first = curve_by_arc_length(lambda t: bezier(start, held, goal, t), goal, task.step_size)
    at_t = parameter_at_length(lambda t: bezier(start, held, goal, t), at * task.step_size)

    def path(second):
        if join == "kink":
            return np.vstack([first[:at], curve_by_arc_length(lambda t: bezier(first[at], second, goal, t), goal,
                                                              task.step_size)])
        return curve_by_arc_length(turning_curve(start, held, goal, at_t, second, from_point=True), goal, task.step_size)

    return max((path(c) for c in controls), key=lambda p: rest_score(task, p, at, goals, target, style))


def scene_ceiling(task: Task, goals, target: int, seed: int, n: int, join: str) -> list[dict]:
    """One record per direction and fraction for one scene, as :func:`scdp.evaluation.authority.scene_authority`."""
    start, goal = task.start_point, np.asarray(goals, dtype=np.float64)[target]
    rng = np.random.default_rng(seed)
    pool = np.array([task.sample_control_point(rng, start, goal) for _ in range(n)])
    curves = [curve_by_arc_length(lambda t, c=c: bezier(start, c, goal, t), goal, task.step_size) for c in pool]
    out = []
    for first, then in DIRECTIONS:
        pick = {s: int(np.argmax([style_score(task, p, goals, target, s) for p in curves])) for s in (first, then)}
        base = curves[pick[first]]
        for f in SWITCH_FRACTIONS:
            at = int(round(f * (len(base) - 1)))
            if at == 0:
                path = curves[pick[then]]
            else:
                later = np.array([task.sample_control_point(rng, base[at], goal) for _ in range(n)])
                path = switched(task, pool[pick[first]], later, at, goals, target, then, join)
            out.append(switch_record(task, path, base, at, goals, target, first, then, f))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    scene_args(p)
    p.add_argument("--curves", type=int, default=200, help="demo curves drawn per pick (default 200)")
    p.add_argument("--out", default="results/authority/ceiling.md")
    args = p.parse_args(argv)
    command = " ".join(["python", "benchmarks/authority_ceiling.py", *(argv if argv is not None else sys.argv[1:])])
    lines = [f"# Style authority the demonstrations allow: the best of {args.curves} demo curves", "",
             f"`{command}`. The scenes of `style_authority.py` (ambiguous validation scenes, seed {args.seed}), "
             "from the task's nominal start; no network: each path is the demo curve that scores best for its style, "
             "a switch follows the best fresh demo curve from the switch point, blended in as the turning demos do "
             "(smooth) or jumped onto (kink: the fresh curve alone). Columns as in `cpu.md`.", ""]
    data = {"command": command, "stream": VALIDATION, "seed": args.seed, "tasks": {}}
    for name, join in ((n, j) for n in args.tasks for j in JOINS):
        task, start, records = get_task(name), time.perf_counter(), []
        for i, (goals, target) in enumerate(scene_sets(task, args.scenes, args.seed, stream=VALIDATION)[AMBIGUOUS]):
            records += [{"scene": i, **r} for r in
                        scene_ceiling(task, goals, target, scene_seed(args.seed, "authority", i), args.curves, join)]
            print(f"{name}, {join} join: scene {i + 1}/{args.scenes}", flush=True)
        rows, minutes = summarise(records), (time.perf_counter() - start) / 60
        data["tasks"][f"{name}/{join}"] = {"records": records, "summary": rows, "minutes": round(minutes, 2)}
        lines += [f"## {name}, {join} join ({args.scenes} scenes, {minutes:.1f} compute-min)", "", *table_lines(rows), ""]
    write_report(args.out, "\n".join(lines), data)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
