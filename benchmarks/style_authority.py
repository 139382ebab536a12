"""Style authority along the motion (issue 76): a style switched on part-way, against the same run unswitched.

Regenerates: `results/authority/cpu.md`, `results/authority/cpu.json`

    python benchmarks/style_authority.py --run results/cpu --methods scdp scdp_paper --out results/authority/cpu.md

A candidate design (results/authority/PROTOCOL.md) is measured the same way on a run of its own, e.g. with the
predictors retrained on every window: copy ``results/cpu/<task>/checkpoints/{base,encoder}`` to
``runs/ew/<task>/checkpoints/``, ``scdp train style --task <task> --style legible|efficient --preset cpu --set
style.early_windows=1.0 --data results/cpu/<task>/demos.zarr --out runs/ew/<task>/checkpoints/style_<style>``,
then this script with ``--run runs/ew --out results/authority/every_window.md``.

For each task, ``--scenes`` ambiguous *validation* scenes (never evaluation ones) are driven by SCDP through
:class:`scdp.policies.control.ControlLoopPolicy` with the style held (efficient, or legible) and with it switched
to the other at fractions 0, 0.15, 0.3, 0.5 and 0.7 of the motion, same scene and noise
(:mod:`scdp.evaluation.authority` says what each column measures), with the robot's own planner (the control
loop's real-time profile). The ratio columns divide by the switch at 0: a style with authority all along keeps a
good share of it at 0.3 (the pass rule: results/authority/PROTOCOL.md). Run it alone for honest minutes.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from scdp.config import PlanningOptions
from scdp.config.planning import PROFILES
from scdp.data.scenes import VALIDATION, scene_seed
from scdp.evaluation.authority import SWITCH_FRACTIONS, scene_authority, summarise, table_lines
from scdp.evaluation.protocol import scene_sets
from scdp.io import write_report
from scdp.keys import AMBIGUOUS
from scdp.policies.loaders import load_method
from scdp.tasks import get_task


def task_table(task_name: str, method: str, run: Path, scenes: int, seed: int,
               profile: str | None = None) -> tuple[list[dict], list[dict], float]:
    task = get_task(task_name)
    start = time.perf_counter()
    options = PlanningOptions.of_entry("control_loop", **({"profile": profile} if profile else {}))
    planner = load_method(method, run / task_name / "checkpoints", task, options)
    records = []
    for i, (goals, target) in enumerate(scene_sets(task, scenes, seed, stream=VALIDATION)[AMBIGUOUS]):
        for r in scene_authority(task, planner, goals, target, scene_seed(seed, "authority", i), SWITCH_FRACTIONS):
            records.append({"scene": i, **r})
        print(f"{task_name} {method}: scene {i + 1}/{scenes}", flush=True)
    return records, summarise(records), (time.perf_counter() - start) / 60


def scene_args(p: argparse.ArgumentParser) -> None:
    """The scenes of the style-authority measurements (also base_spread.py's and authority_ceiling.py's)."""
    p.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    p.add_argument("--scenes", type=int, default=12, help="ambiguous validation scenes per task (default 12)")
    p.add_argument("--seed", type=int, default=76, help="the validation scenes' seed (default 76: results/SEEDS.md)")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", default="results/cpu", help="a reproduction whose <task>/checkpoints hold SCDP")
    scene_args(p)
    p.add_argument("--methods", nargs="+", default=["scdp"], help="SCDP variants to load (e.g. scdp scdp_paper)")
    p.add_argument("--profile", choices=PROFILES, default=None,
                   help="the planner's profile (default: the control loop's, realtime; trained: the checkpoints' own "
                        "sampler, every chunk from noise)")
    p.add_argument("--out", default="results/authority/cpu.md")
    args = p.parse_args(argv)
    command = " ".join(["python", "benchmarks/style_authority.py", *(argv if argv is not None else sys.argv[1:])])
    lines = [f"# Style authority along the motion: `{args.run}`", "", f"`{command}`. Ambiguous validation scenes "
             "(seed %d), SCDP through ControlLoopPolicy (the control loop's planner unless the command says --profile), "
             "the style held or switched at a fraction of the motion, same "
             "scene and noise (scdp.evaluation.authority). separation: median distance of the switched path from the "
             "unswitched one after the switch (m); gain: path-length observer accuracy over the rest of the motion, "
             "legible-styled minus efficient-styled; detour: the rest's length over its straight distance. Ratios: "
             "to the switch at 0." % args.seed, ""]
    data = {"command": command, "stream": VALIDATION, "seed": args.seed, "tasks": {}}
    for name, method in ((n, m) for n in args.tasks for m in args.methods):
        records, rows, minutes = task_table(name, method, Path(args.run), args.scenes, args.seed, args.profile)
        data["tasks"][f"{name}/{method}"] = {"records": records, "summary": rows, "minutes": round(minutes, 2)}
        lines += [f"## {name}, {method} ({args.scenes} scenes, {minutes:.1f} compute-min)", "", *table_lines(rows), ""]
    write_report(args.out, "\n".join(lines), data)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
