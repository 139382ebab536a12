"""The real-time gate, round 2 (issue 59): margins that protect what they claim to. Protocol, then run.

Regenerates: `results/benchmarks/realtime_gate2.md`

    python benchmarks/realtime_gate2.py --protocol-commit C --out results/benchmarks/realtime_gate2

Why a round 2: round 1 (``benchmarks/realtime_gate.py``, results/benchmarks/realtime_gate.md) tolerated a
T_fa loss of 0.025 per method, more than SCDP's smallest advantage it was there to keep (SCDP − DP on
Block Reach's clear scenes, +0.022); it never compared SCDP − DP under the candidate with SCDP − DP under
the default; its sensitivity arm (films off) failed by construction; its margins were written after the
same candidate had failed an earlier gate; and its N = 400 null run was overwritten by the N = 800 one.

Protocol, committed before its one run and not edited after it:

* **Scenes.** Validation stream only (:data:`scdp.data.scenes.VALIDATION`), **seed 59**, which no earlier
  gate or choice used (they used 2 and 50): 400 ambiguous + 400 clear scenes per task, both tasks. Every
  planner plans the same scenes from the same start states; the sampler noise comes from each scene's
  own generator (the null check's from another), as in round 1 (``realtime_gate.plan``).
* **Methods.** dp, scdp, scdp_legible, scdp_efficient, scdp_blend, from the committed cpu checkpoints
  (``--run``, results/cpu at the protocol commit).
* **Default** = the checkpoints' own sampler (the cpu preset's DDPM-20), cold, torch (profile ``trained``).
  **Candidate** = the ``realtime`` profile: DDPM respaced to 8 steps, warm-started at step 4; batched
  under torch here (ONNX Runtime runs the same network at batch 1).
* **Rules** (:func:`scdp.evaluation.noninferiority.round_two`, from results/cpu/claims.json at the protocol
  commit; the numbers are printed into the report): one-sided 95 % scene-bootstrap lower bounds on
  candidate − default, under **both** readings of D̂ and Ê (per scene; over the training data, ranges
  from results/cpu/results.json):

  - T_fa, every method, per task and scene set: margin = −½ × the smallest |SCDP − X| T_fa effect of the
    committed run in that cell and reading whose 95 % interval excludes zero, X the methods the claims and
    targets compare SCDP with (DP, tuned LD, the Dataset row). Per scene: Block Reach ambiguous −0.0249,
    clear −0.0111 (half of SCDP − DP, +0.022); Navigation ambiguous −0.0402, clear −0.0448. Over the
    training data: Block Reach −0.0090, −0.0203; Navigation −0.0046, −0.0055;
  - the **contrast** (candidate SCDP − candidate DP) − (default SCDP − default DP), T_fa, per task, scene set
    and reading: margin = −½ × the committed SCDP − DP effect of that cell (a cell where it is not
    established takes its reading's smallest). Per scene: Block Reach −0.0265, −0.0111 (the smallest
    SCDP − DP effect, +0.022, held to half); Navigation −0.0736, −0.0649. Over the training data: Block
    Reach −0.0090, −0.0203; Navigation −0.0073 (ambiguous: +0.006 [−0.000, +0.012] is no established
    effect, so it takes the smallest, clear's), −0.0073;
  - kept from round 1 (per scene; the observers do not depend on the reading): ambiguous D̂ ≥ −0.05 for
    scdp and scdp_legible; clear Ê ≥ −0.05 for scdp and scdp_efficient; the path-length observer right
    at 50 % of the motion, ambiguous, ≥ −0.08 for scdp and scdp_legible; the candidate's success ≥ 0.99
    for every method and set; its forced-style D̂ gap ≥ 90 % of the default's in each scene set.

  The gate passes when every check holds on both tasks.
* **Null check first**: the default against itself, only the sampler noise redrawn. It must pass. If it
  fails on either task, N doubles to 800 + 800 (same seed) and the null check runs again, then every arm
  at that N; the margins never change. If it fails at 800 too, the gate is uninformative. Every null run
  is kept in the JSON (``null_runs``: N and the whole verdict), the first included.
* **Near-margin arm**: the candidate with its films at half strength (``film_scale`` 0.5: γ = 1 + ½(γ − 1),
  β = ½β, for every SCDP method; dp as in the gate). It keeps the sampler and about half of every style
  effect, so it erodes SCDP − DP by about half where that effect is smallest: a useful gate must fail it.
  **Films-off arm**: the candidate with style ``none`` (round 1's sensitivity arm), must fail too.
* **After**: the gate passes → ``realtime`` stays the default of ``scdp plan``, ``serve``, ``deploy`` and
  ``ControlLoopPolicy``. It fails on either task → those entry points go back to ``trained``
  (``scdp.config.planning.ENTRY_PROFILES``; one planner serves both tasks there), the note names each failed
  check and by how much; nothing is tuned on these scenes.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from realtime import matmul_gflops  # sibling benchmarks
from realtime_gate import DEFAULT, FAST, METHODS, plan

from scdp.data.scenes import VALIDATION
from scdp.evaluation.noninferiority import GATE_MIN_SUCCESS, MIN_GAP_SHARE, ONE_SIDED_LEVEL, failed, round_two, verdict
from scdp.evaluation.normalised import read_ranges
from scdp.evaluation.protocol import scene_sets
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.tasks import get_task

SEED, SCENES = 59, 400
ARMS = {"null": "the default again, its sampler noise redrawn (must pass)", "gate": "the fast planner",
        "near_margin": "the fast planner, films at half strength (must fail)",
        "films_off": "the fast planner, films off (must fail)"}


def check_row(c: dict) -> str:
    ok = "yes" if c["holds"] else "**no**"
    reading = c.get("reading", "scene")
    if c.get("missing"):
        return f"| {c['check']} | {c.get('method', '')} | {c.get('scene_set', '')} | {reading} | – | – | – | {ok} |"
    if c["check"] in ("bound", "contrast"):
        name = "contrast T_fa" if c["check"] == "contrast" else c["measure"]
        return (f"| {name} | {c['method']} | {c['scene_set']} | {reading} | {c['mean']:+.4f} | {c['lo']:+.4f} | "
                f"{c['margin']:+.4f} | {ok} |")
    if c["check"] == "success":
        return (f"| success | {c['method']} | {c['scene_set']} | – | {c['rate']:.3f} (default {c['default_rate']:.3f}) | – | "
                f">= {GATE_MIN_SUCCESS} | {ok} |")
    return (f"| forced D̂ gap | legible - efficient | {c['scene_set']} | scene | {c['candidate']:.3f} (default "
            f"{c['default']:.3f}) | {100 * c['share']:.0f} % | >= {100 * MIN_GAP_SHARE:.0f} % | {ok} |")


def arm_sections(arms: dict, labels: dict) -> list[str]:
    """Each arm's section: its verdict, its failed checks, and every check per task (``labels``: each arm's words)."""
    lines = []
    for name, block in arms.items():
        lines += [f"## {name}: {labels[name]}: {'PASSES' if block['passes'] else 'FAILS'}", ""]
        misses = failed(block)
        if misses:
            lines += [f"Failed checks ({len(misses)}):", ""] + [f"- {m}" for m in misses] + [""]
        for task, t in block["tasks"].items():
            lines += [f"### {task}: {'passes' if t['passes'] else 'fails'}", "",
                      "| check | method | set | reading | Δ mean | bound | margin | holds |", "|---|---|---|---|---|---|---|---|"]
            lines += [check_row(c) for c in t["checks"]] + [""]
    return lines


def markdown(result: dict) -> str:
    lines = ["# The real-time gate, round 2: margins from the effects they protect, under both readings", "",
             f"`{result['command']}` ({result['compute_minutes']:.1f} compute-min; matmul {result['gflops']:.0f} GFLOP/s "
             f"fp32 on this machine). Protocol: the docstring of `benchmarks/realtime_gate2.py`, committed in "
             f"{result['protocol_commit']} before this run. {result['scenes']} ambiguous + {result['scenes']} clear "
             f"validation scenes per task (seed {SEED}); Δ = candidate − default; 'bound' is the one-sided 95 % "
             f"scene-bootstrap lower bound (the lower end of a {100 * ONE_SIDED_LEVEL:.0f} % interval).", "",
             "Margins (`round_two`, from results/cpu/claims.json): T_fa per cell " +
             "; ".join(f"{reading}: " + ", ".join(f"{cell} {m:+.4f}" for cell, m in cells.items())
                       for reading, cells in result["rules"]["t_fa"].items()) +
             ". Contrast per cell: " + "; ".join(f"{reading}: " + ", ".join(f"{cell} {m:+.4f}" for cell, m in cells.items())
                                                 for reading, cells in result["rules"]["contrast"].items()) + ".", "",
             "| arm | candidate | verdict |", "|---|---|---|"]
    lines += [f"| {name} | {ARMS[name]} | {'PASSES' if block['passes'] else 'FAILS'} |" for name, block in result["arms"].items()]
    lines += ["", "Null check runs (each kept whole in the JSON): "
              + "; ".join(f"N = {run['scenes']}: {'passes' if run['verdict']['passes'] else 'fails'}" for run in result["null_runs"]),
              ""]
    for run in result["null_runs"]:
        misses = failed(run["verdict"])
        if misses:
            lines += [f"Null check at N = {run['scenes']}, failed checks:", ""] + [f"- {m}" for m in misses] + [""]
    return "\n".join(lines + arm_sections(result["arms"], ARMS))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", type=Path, default=Path("results/cpu"), help="the committed reproduction (checkpoints, "
                   "claims.json for the margins, results.json for the training-data ranges)")
    p.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    p.add_argument("--scenes", type=int, default=SCENES, help=f"scenes per set before any doubling (protocol: {SCENES})")
    p.add_argument("--protocol-commit", default="", help="the commit that holds this protocol (for the report)")
    p.add_argument("--out", type=Path, default=Path("results/benchmarks/realtime_gate2"), help="writes OUT.json and OUT.md")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    rules = round_two(json.loads((args.run / "claims.json").read_text()))
    ranges = read_ranges(json.loads((args.run / "results.json").read_text())["normalisation_ranges"])
    tasks = {name: get_task(name) for name in args.tasks}
    result = {"command": "python benchmarks/realtime_gate2.py " + " ".join(argv if argv is not None else sys.argv[1:]),
              "protocol_commit": args.protocol_commit, "gflops": matmul_gflops(), "seed": SEED,
              "rules": {"t_fa": rules.t_fa, "contrast": rules.contrast, "bounds": [b.__dict__ for b in rules.bounds]},
              "ranges": {k: v.to_dict() for k, v in ranges.items()}, "arms": {}, "null_runs": []}
    ck = {name: args.run / name / "checkpoints" for name in tasks}

    def every(planning, sets, **how) -> list:  # every task and method
        return [r for t in tasks for m in METHODS for r in plan(tasks[t], ck[t], m, planning, sets[t], seed=SEED, **how)]

    def judge(candidate) -> dict:
        return verdict(default, candidate, rules, ranges)

    default, redrawn, planned = [], [], 0
    for n in (args.scenes, 2 * args.scenes):  # the null check decides N (it doubles once, never the margins)
        sets = {name: {k: v for k, v in scene_sets(task, n, SEED, stream=VALIDATION).items() if k in (AMBIGUOUS, CLEAR)}
                for name, task in tasks.items()}  # the first scenes of a larger N are the smaller N's (same seed)
        default += every(DEFAULT, sets, first=planned)
        redrawn += every(DEFAULT, sets, first=planned, noise="/null")
        planned = n
        null = judge(redrawn)
        result["null_runs"].append({"scenes": n, "verdict": null})
        result["arms"]["null"], result["scenes"] = null, n
        print(f"null check at N = {n}: {'passes' if null['passes'] else 'fails'}", *failed(null), sep="\n  ", flush=True)
        if null["passes"]:
            break
    result["arms"]["gate"] = judge(every(FAST, sets))
    result["arms"]["near_margin"] = judge(every(FAST, sets, film_scale=0.5))
    result["arms"]["films_off"] = judge(every(FAST, sets, films=False))
    arms = result["arms"]
    result["informative"] = arms["null"]["passes"] and not arms["near_margin"]["passes"] and not arms["films_off"]["passes"]
    result["compute_minutes"] = (time.perf_counter() - t0) / 60
    write_json(args.out.with_suffix(".json"), result)
    write_text(args.out.with_suffix(".md"), markdown(result))
    print(markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
