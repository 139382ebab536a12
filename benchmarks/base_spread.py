"""Why a style switched on mid-motion moves so little (issue 76): how many ways forward the frozen base still
offers at a state part-way through a motion, and how far the films move one chunk there.

Regenerates: `results/authority/spread_cpu.md`, `results/authority/spread_turning_point.md`,
`results/authority/spread_turning_all.md` (and their .json)

    python benchmarks/base_spread.py --run results/cpu --out results/authority/spread_cpu.md
    python benchmarks/base_spread.py --run runs/turning_point --out results/authority/spread_turning_point.md
    python benchmarks/base_spread.py --run runs/turning_all --out results/authority/spread_turning_all.md

SCDP's films modulate a frozen Diffusion Policy, and its style predictors learn them from the demos: from a
state where the demos show one way on, a style has nothing to change. A quadratic Bézier demo that heads for its
goal from some point goes straight from there (its remaining control point lies on its tangent), so the demos
show no way to bend once a path aims at its goal. Per ambiguous validation scene (the scenes and seeds of
``style_authority.py``), SCDP is driven efficient to the state at fraction f of the motion; from that state's
history one chunk is planned cold with ``--draws`` noise seeds, by the base alone (style ``none``), and with
each style's films. Per fraction:

* ``spread``: the base's ways forward, the median angle between its chunks' headings (task space, from the
  state to the chunk's end) and their mean heading;
* ``films``: what a style switch does to that chunk, the median angle between the legible- and the
  efficient-styled chunk's heading, drawn with the same noise.

Angles, not distances: a chunk from rest is short, one at speed long.

Ratios divide by the fraction 0: a base whose spread collapses mid-motion leaves the films nothing to choose.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from style_authority import scene_args

from scdp.config import PlanningOptions
from scdp.data.scenes import VALIDATION, scene_seed
from scdp.evaluation.authority import SWITCH_FRACTIONS
from scdp.evaluation.dynamic import EFFICIENT, LEGIBLE
from scdp.evaluation.protocol import scene_sets
from scdp.io import write_report
from scdp.keys import AMBIGUOUS
from scdp.policies.control import ControlLoopPolicy
from scdp.policies.loaders import load_method
from scdp.tasks import Task, get_task


def efficient_states(task: Task, planner, goals, target: int, seed: int) -> np.ndarray:
    """The states (N + 1, S) of one episode planned efficient through :class:`ControlLoopPolicy`."""
    env = task.make_env()
    obs, _ = env.reset(seed=seed, options={"goals": goals, "target": int(target)})
    planner.set_style(EFFICIENT)
    policy = ControlLoopPolicy(planner, task, goals, target, seed=seed)
    policy.reset(obs["state"])
    states = [obs["state"]]
    while True:
        obs, _, terminated, truncated, _ = env.step(policy.select_action(obs["state"]))
        states.append(obs["state"])
        if terminated or truncated:
            return np.asarray(states)


def chunk_heading(task: Task, planner, goals, target: int, history: np.ndarray, style: str, seed: int) -> np.ndarray:
    """The unit task-space direction (G,) from the last state of ``history`` to the end of the chunk planned cold
    from it with ``style`` and noise ``seed``."""
    planner.set_style(style)
    policy = ControlLoopPolicy(planner, task, goals, target, seed=seed)
    policy.reset()
    policy.observe(history)
    move = task.task_space(policy.predict_action_chunk()[-1:])[0] - task.task_space(history[-1:])[0]
    return move / max(float(np.linalg.norm(move)), 1e-12)


def degrees(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles (deg) between unit directions ``a`` and ``b`` (n, G), row by row."""
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


def scene_spread(task: Task, planner, goals, target: int, seed: int, draws: int) -> list[dict]:
    """One record per fraction for one scene (module docstring); draw k's noise: ``scene_seed(seed, "spread", k)``."""
    states = efficient_states(task, planner, goals, target, seed)
    noise = [scene_seed(seed, "spread", k) for k in range(draws)]
    out = []
    for f in SWITCH_FRACTIONS:
        history = states[: int(round(f * (len(states) - 1))) + 1]
        heads = {s: np.array([chunk_heading(task, planner, goals, target, history, s, n) for n in noise])
                 for s in ("none", LEGIBLE, EFFICIENT)}
        mean = heads["none"].mean(0) / max(float(np.linalg.norm(heads["none"].mean(0))), 1e-12)
        out.append({"fraction": f, "spread": float(np.median(degrees(heads["none"], mean[None]))),
                    "films": float(np.median(degrees(heads[LEGIBLE], heads[EFFICIENT])))})
    return out


def summarise(records: list[dict]) -> list[dict]:
    rows = []
    for f in SWITCH_FRACTIONS:
        group = [r for r in records if r["fraction"] == f]
        rows.append({"fraction": f, **{k: float(np.median([r[k] for r in group])) for k in ("spread", "films")}})
    for row in rows:
        for k in ("spread", "films"):
            row[f"{k}_ratio"] = row[k] / rows[0][k] if rows[0][k] > 0 else float("nan")
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", default="results/cpu", help="a reproduction whose <task>/checkpoints hold SCDP")
    scene_args(p)
    p.add_argument("--draws", type=int, default=16, help="noise seeds per state (default 16)")
    p.add_argument("--out", default="results/authority/spread_cpu.md")
    args = p.parse_args(argv)
    command = " ".join(["python", "benchmarks/base_spread.py", *(argv if argv is not None else sys.argv[1:])])
    lines = [f"# Ways forward the frozen base offers part-way through a motion: `{args.run}`", "",
             f"`{command}`. Ambiguous validation scenes (seed {args.seed}), SCDP driven efficient to fraction f of the "
             f"motion, then one chunk planned cold from there with {args.draws} noise seeds (the control loop's "
             "planner). spread: median angle of the base's chunk headings from their mean (deg); films: median angle "
             "between the legible- and efficient-styled chunk headings, same noise (deg). Ratios: to f = 0.", ""]
    data = {"command": command, "stream": VALIDATION, "seed": args.seed, "tasks": {}}
    for name in args.tasks:
        task, start, records = get_task(name), time.perf_counter(), []
        planner = load_method("scdp", Path(args.run) / name / "checkpoints", task, PlanningOptions.of_entry("control_loop"))
        for i, (goals, target) in enumerate(scene_sets(task, args.scenes, args.seed, stream=VALIDATION)[AMBIGUOUS]):
            seed = scene_seed(args.seed, "authority", i)
            records += [{"scene": i, **r} for r in scene_spread(task, planner, goals, target, seed, args.draws)]
            print(f"{name}: scene {i + 1}/{args.scenes}", flush=True)
        rows, minutes = summarise(records), (time.perf_counter() - start) / 60
        data["tasks"][name] = {"records": records, "summary": rows, "minutes": round(minutes, 2)}
        lines += [f"## {name} ({args.scenes} scenes, {minutes:.1f} compute-min)", "",
                  "| f | base spread (deg) | ratio | films: legible vs efficient (deg) | ratio |", "|---|---|---|---|---|"]
        lines += [f"| {r['fraction']:.2f} | {r['spread']:.2f} | {r['spread_ratio']:.3f} | {r['films']:.2f} | "
                  f"{r['films_ratio']:.3f} |" for r in rows] + [""]
    write_report(args.out, "\n".join(lines), data)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
