"""The real-time gate, round 3 (issue 79): a 2-call warm start as the candidate, and an arm just past the dataset margins.

Regenerates: `results/benchmarks/realtime_gate3_protocol.md`
(with --protocol-only: this protocol and its margins, written and committed before the run; the run itself
writes results/benchmarks/realtime_gate3.md).

    python benchmarks/realtime_gate3.py --protocol-only
    python benchmarks/realtime_gate3.py --protocol-commit C --out results/benchmarks/realtime_gate3

Protocol, committed before its one run and not edited after it:

* **Round 2's protocol unchanged** (``benchmarks/realtime_gate2.py``'s docstring), except for the items
  below: the same methods (dp, scdp, scdp_legible, scdp_efficient, scdp_blend), the same default (the
  checkpoints' DDPM-20, cold, torch), the same rules (:func:`scdp.evaluation.noninferiority.round_two`
  from results/cpu/claims.json; margins printed into the report), both readings, the SCDP − DP contrast,
  the near-margin arm (films at half strength, must fail) and the films-off arm (must fail). The models
  are the committed cpu models at the protocol commit.
* **Candidate**: DDPM-8 warm-started at step **6** (2 network calls per warm chunk; the real-time default
  makes 4), chosen on results/benchmarks/style_fidelity.md (validation seed 79): it kept 0.93 and 0.90 of
  the forced-style D̂ gap, and its paths lie closer to the full sampler's than the full sampler's
  own noise floor. Batched under torch here, as in round 2.
* **Scenes**: validation stream, **seed 81** (no gate and no choice has used it), **800 + 800 per task
  from the start**. Round 2's null check needed 800. If the null check fails at 800 the gate is
  uninformative: nothing doubles, and the default stays.
* **The arm round 2 lacked: just past the dataset reading's margins.** It is the candidate with its films
  scaled by s_past. Round 2's near-margin arm failed only on checks of the per-scene reading, so the
  dataset half of the gate has so far been shown to catch only films fully off. s_past is calibrated
  before any scene of seed 81 is planned, on validation **seed 80**, 400 + 400 scenes per task, dp and
  scdp only:
  - the default is planned once, and the candidate at film scales 0.9, 0.8, 0.7, 0.6 and 0.5;
  - s_past is the largest of those scales at which, in some task and scene set, the dataset reading's
    contrast mean (candidate SCDP − candidate DP) − (default SCDP − default DP) is at or below 1.5 × that
    cell's margin;
  - where no scale reaches it, s_past = 0.5 (round 2's arm).

  The calibration and its choice are written into the report. The arm must fail.
* **Informative** when the null passes and the near-margin, films-off and past-dataset-margin arms
  all fail.
* **After.** The gate passes and is informative → the candidate becomes the real-time default
  (``scdp.config.planning.REALTIME``'s ``warm_skip``: 6) for ``scdp plan``, ``serve``, ``deploy`` and the
  control loop. It fails → the default stays DDPM-8 warm from step 4. The note names each failed check
  and by how much, and nothing is tuned on seed 81.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from realtime import matmul_gflops  # sibling benchmarks
from realtime_gate import DEFAULT, plan
from realtime_gate2 import arm_sections

from scdp.config import PlanningOptions
from scdp.data.scenes import VALIDATION
from scdp.evaluation.noninferiority import ONE_SIDED_LEVEL, round_two, verdict
from scdp.evaluation.normalised import read_ranges
from scdp.evaluation.protocol import scene_sets
from scdp.io import write_report, write_text
from scdp.keys import AMBIGUOUS, CLEAR, DATASET_NORMALISATION
from scdp.tasks import get_task

SEED, SCENES = 81, 800
CALIBRATION_SEED, CALIBRATION_SCENES, SCALES, PAST = 80, 400, (0.9, 0.8, 0.7, 0.6, 0.5), 1.5
CANDIDATE = PlanningOptions(sampler="ddpm", steps=8, warm_skip=6)
METHODS = ("dp", "scdp", "scdp_legible", "scdp_efficient", "scdp_blend")
MUST_FAIL = ("near_margin", "films_off", "past_dataset_margin")


@dataclass(frozen=True)
class Round:
    """One round of this protocol: its script, its seeds and its candidate (every other rule is shared).

    ``candidate(task, checkpoints, method, sets, seed, **how)`` plans ``method`` under the candidate
    (``how``: :func:`realtime_gate.plan`'s ``films``, ``film_scale``) and returns its scored records;
    ``record`` is the candidate as the report's JSON names it (None: the gate arm's words)."""

    number: int
    title: str
    doc: str
    seed: int
    calibration_seed: int
    candidate: Callable[..., list]
    arms: dict
    record: dict | None = None


def warm_from_six(task, checkpoints, method, sets, seed, **how) -> list:
    return plan(task, checkpoints, method, CANDIDATE, sets, seed=seed, **how)


ROUND_THREE = Round(3, "a 2-call warm start, and an arm just past the dataset margins", __doc__, SEED, CALIBRATION_SEED,
                    warm_from_six, {"null": "the default again, its sampler noise redrawn (must pass)",
                                    "gate": "DDPM-8 warm-started at step 6",
                                    "near_margin": "the candidate, films at half strength (must fail)",
                                    "films_off": "the candidate, films off (must fail)",
                                    "past_dataset_margin": "the candidate, films scaled to just past the dataset "
                                                           "reading's margins (must fail)"},
                    {"sampler": CANDIDATE.sampler, "steps": CANDIDATE.steps, "warm_skip": CANDIDATE.warm_skip})


def scene_sets_of(tasks: dict, n: int, seed: int) -> dict:
    return {name: {k: v for k, v in scene_sets(task, n, seed, stream=VALIDATION).items() if k in (AMBIGUOUS, CLEAR)}
            for name, task in tasks.items()}


def calibrate(round_: Round, tasks: dict, ck: dict, rules, ranges, n: int) -> dict:
    """s_past on the calibration seed (the protocol): the largest scale whose dataset-reading contrast reaches 1.5 × a margin."""
    seed = round_.calibration_seed
    sets = scene_sets_of(tasks, n, seed)
    default = [r for t in tasks for m in ("dp", "scdp") for r in plan(tasks[t], ck[t], m, DEFAULT, sets[t], seed=seed)]
    rows, chosen = [], None
    for scale in SCALES:
        candidate = [r for t in tasks for m in ("dp", "scdp")
                     for r in round_.candidate(tasks[t], ck[t], m, sets[t], seed, film_scale=scale)]
        checks = verdict(default, candidate, rules, ranges)
        cells = [{"task": task, "scene_set": c["scene_set"], "mean": c["mean"], "margin": c["margin"]}
                 for task, t in checks["tasks"].items() for c in t["checks"]
                 if c["check"] == "contrast" and c.get("reading") == DATASET_NORMALISATION and not c.get("missing")]
        past = [c for c in cells if c["mean"] <= PAST * c["margin"]]
        rows.append({"scale": scale, "cells": cells, "past": bool(past)})
        if past:
            chosen = scale
            break
    return {"seed": seed, "scenes": n, "scales": rows, "s_past": chosen if chosen is not None else SCALES[-1],
            "reached": chosen is not None}


def protocol_markdown(round_: Round, rules) -> str:
    """The protocol as committed before the run, with the margins it will judge by (from the committed claims)."""
    margins = ["| rule | reading | cell | margin |", "|---|---|---|---|"]
    for name, table in (("T_fa, every method", rules.t_fa), ("SCDP − DP contrast", rules.contrast)):
        margins += [f"| {name} | {reading} | {cell} | {m:+.4f} |" for reading, cells in table.items() for cell, m in cells.items()]
    margins += [f"| {b.measure} | scene | {', '.join(b.methods or ['every method'])} ({b.scene_set}) | {b.margin:+.4f} |"
                for b in rules.bounds]
    text = round_.doc.split("Protocol, committed before its one run and not edited after it:", 1)[1]
    script = f"benchmarks/realtime_gate{round_.number}.py"
    return "\n".join([f"# The real-time gate, round {round_.number}: protocol (committed before the run)", "",
                      f"`python {script} --protocol-only`", "", text.strip(), "",
                      "## The margins it judges by (`round_two`, from results/cpu/claims.json)", "", *margins, ""])


def markdown(round_: Round, result: dict) -> str:
    cal = result["calibration"]
    lines = [f"# The real-time gate, round {round_.number}: {round_.title}", "",
             f"`{result['command']}` ({result['compute_minutes']:.1f} compute-min; matmul {result['gflops']:.0f} GFLOP/s "
             f"fp32). Protocol: the docstring of `benchmarks/realtime_gate{round_.number}.py`, committed in "
             f"{result['protocol_commit']} before this run. {result['scenes']} ambiguous + {result['scenes']} clear validation "
             f"scenes per task (seed {round_.seed}); Δ = candidate − default; 'bound' is the one-sided 95 % scene-bootstrap "
             f"lower bound (the lower end of a {100 * ONE_SIDED_LEVEL:.0f} % interval).", "",
             f"Calibration of the past-dataset-margin arm (seed {cal['seed']}, {cal['scenes']} + {cal['scenes']} scenes, dp "
             f"and scdp): s_past = {cal['s_past']:g} ({'reached' if cal['reached'] else 'not reached: round 2 s 0.5'}).", "",
             "| scale | past 1.5 × a margin | dataset-reading contrast means (cell: mean / margin) |", "|---|---|---|"]
    lines += [f"| {row['scale']:g} | {'yes' if row['past'] else 'no'} | " + "; ".join(
        f"{c['task']}/{c['scene_set']}: {c['mean']:+.4f} / {c['margin']:+.4f}" for c in row["cells"]) + " |" for row in cal["scales"]]
    lines += ["", "| arm | candidate | verdict |", "|---|---|---|"]
    lines += [f"| {name} | {round_.arms[name]} | {'PASSES' if block['passes'] else 'FAILS'} |" for name, block in result["arms"].items()]
    lines += ["", f"Informative (null passes, every must-fail arm fails): {'yes' if result['informative'] else '**no**'}", ""]
    return "\n".join(lines + arm_sections(result["arms"], round_.arms))


def run_round(round_: Round, argv=None) -> int:
    """The command line of a round: its protocol (``--protocol-only``), or its one run."""
    name = f"realtime_gate{round_.number}"
    p = argparse.ArgumentParser(description=round_.doc.split("\n\n")[0])
    p.add_argument("--run", type=Path, default=Path("results/cpu"), help="the committed reproduction")
    p.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    p.add_argument("--scenes", type=int, default=SCENES, help=f"scenes per set (protocol: {SCENES})")
    p.add_argument("--calibration-scenes", type=int, default=CALIBRATION_SCENES,
                   help=f"scenes per set of the calibration (protocol: {CALIBRATION_SCENES})")
    p.add_argument("--protocol-commit", default="", help="the commit that holds this protocol (for the report)")
    p.add_argument("--out", type=Path, default=Path(f"results/benchmarks/{name}"), help="writes OUT.json and OUT.md")
    p.add_argument("--protocol-only", action="store_true",
                   help="write OUT_protocol.md (this protocol and the margins from --run's claims.json) and stop")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    rules = round_two(json.loads((args.run / "claims.json").read_text()))
    if args.protocol_only:
        write_text(args.out.parent / f"{args.out.name}_protocol.md", protocol_markdown(round_, rules))
        return 0
    ranges = read_ranges(json.loads((args.run / "results.json").read_text())["normalisation_ranges"])
    tasks = {t: get_task(t) for t in args.tasks}
    ck = {t: args.run / t / "checkpoints" for t in tasks}
    result = {"command": f"python benchmarks/{name}.py " + " ".join(argv if argv is not None else sys.argv[1:]),
              "protocol_commit": args.protocol_commit, "gflops": matmul_gflops(), "seed": round_.seed, "scenes": args.scenes,
              "candidate": round_.arms["gate"] if round_.record is None else round_.record,
              "rules": {"t_fa": rules.t_fa, "contrast": rules.contrast, "bounds": [b.__dict__ for b in rules.bounds]},
              "arms": {}}
    result["calibration"] = calibrate(round_, tasks, ck, rules, ranges, args.calibration_scenes)  # before any gate scene
    sets = scene_sets_of(tasks, args.scenes, round_.seed)

    def default(**how) -> list:
        return [r for t in tasks for m in METHODS for r in plan(tasks[t], ck[t], m, DEFAULT, sets[t], seed=round_.seed, **how)]

    def candidate(**how) -> list:
        return [r for t in tasks for m in METHODS for r in round_.candidate(tasks[t], ck[t], m, sets[t], round_.seed, **how)]

    reference, arms = default(), result["arms"]
    arms["null"] = verdict(reference, default(noise="/null"), rules, ranges)
    if arms["null"]["passes"]:
        arms["gate"] = verdict(reference, candidate(), rules, ranges)
        arms["near_margin"] = verdict(reference, candidate(film_scale=0.5), rules, ranges)
        arms["films_off"] = verdict(reference, candidate(films=False), rules, ranges)
        arms["past_dataset_margin"] = verdict(reference, candidate(film_scale=result["calibration"]["s_past"]), rules, ranges)
    result["informative"] = bool(arms["null"]["passes"] and all(a in arms and not arms[a]["passes"] for a in MUST_FAIL))
    result["compute_minutes"] = (time.perf_counter() - t0) / 60
    text = markdown(round_, result)
    write_report(args.out.with_suffix(".md"), text, result)  # the markdown and its JSON beside it
    print(text)
    return 0


def main(argv=None) -> int:
    return run_round(ROUND_THREE, argv)


if __name__ == "__main__":
    sys.exit(main())
