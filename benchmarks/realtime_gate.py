"""The real-time gate (issue 50): is the fast planner non-inferior to the default? Protocol, then run.

Regenerates: `results/benchmarks/realtime_gate.md`

    python benchmarks/realtime_gate.py --run results/cpu --out results/benchmarks/realtime_gate

Protocol, committed before its one run and not edited after it:

* **Scenes.** Validation stream only (:data:`scdp.data.scenes.VALIDATION`), seed 50, which no earlier
  gate used (they used 2): 400 ambiguous + 400 clear scenes per task, both tasks. Every planner plans
  the same scenes from the same start states (``scene_seed(50, set, i)``); the sampler noise comes
  from each scene's own generator, seeded from the same stream (the null check's from another).
* **Methods.** dp, scdp, scdp_legible, scdp_efficient, scdp_blend, from the cpu preset's committed
  checkpoints (``--run``).
* **Default** = the checkpoints' own sampler (the cpu preset's DDPM-20), cold, torch.
  **Fast** = the proposed default for the paths a robot uses: DDPM respaced to 8 steps, warm-started
  at step 4 (``--steps 8 --warm-skip 4``). It is run batched under torch here; at batch 1 ONNX
  Runtime runs the same network (``--runtime auto``; parity to 1e-4 in results/benchmarks/onnx_parity.md).
* **Verdict** (:mod:`scdp.evaluation.noninferiority`, margins fixed there): one-sided 95 %
  scene-bootstrap lower bounds on fast - default: T_fa >= -0.025 per method and set; ambiguous D̂
  >= -0.05 for scdp and scdp_legible; clear Ê >= -0.05 for scdp and scdp_efficient; path-length
  observer right at 50 % of the motion, ambiguous, >= -0.08 for scdp and scdp_legible; success of
  the fast planner >= 0.99 for every method and set; its forced-style D̂ gap (scdp_legible -
  scdp_efficient) >= 90 % of the default's in each scene set. The gate passes when every check
  holds on both tasks.
* **Null check first**: the default against itself, same scenes and start states, only the sampler
  noise redrawn (``scene_seed(50, set + "/null", i)``). It must pass. If it fails on either task, N
  doubles to 800 + 800 (the same seed) and the null check runs again, then the gate at that N; the
  margins never change. If it fails at 800 too, the gate is reported as uninformative.
* **Sensitivity check**: the fast planner with its films off (every SCDP method planned with style
  ``none``: the frozen base alone; dp as in the gate) must fail the same verdict. Reported beside it.
* **After**: pass → the fast planner becomes the default of ``scdp plan``, ``scdp serve``, ``scdp
  deploy`` and ``ControlLoopPolicy``; ``reproduce`` and ``evaluate`` keep the preset's sampler. Fail →
  the defaults stay, the note names the failed bound and by how much; nothing is tuned on these scenes.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from realtime import matmul_gflops  # a sibling benchmark

from scdp.config import PlanningOptions
from scdp.data.scenes import VALIDATION, scene_seed
from scdp.evaluation.noninferiority import GATE_MIN_SUCCESS, MIN_GAP_SHARE, ONE_SIDED_LEVEL, failed, verdict
from scdp.evaluation.protocol import scene_sets
from scdp.evaluation.records import scene_bounds, score_rollout
from scdp.evaluation.rollout import rollout
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR, SCDP_METHODS
from scdp.policies.loaders import load_method
from scdp.tasks import get_task

SEED, SCENES, METHODS = 50, 400, ("dp", "scdp", "scdp_legible", "scdp_efficient", "scdp_blend")
DEFAULT = PlanningOptions()
FAST = PlanningOptions(sampler="ddpm", steps=8, warm_skip=4)


def planner_name(method: str, films: bool = True, student: bool = False) -> str:
    """The planner that plans ``method`` (dp or an SCDP method): itself, or with ``student`` the few-step
    student's counterpart (``scdp_legible`` -> ``scdp_student:legible``); without ``films``, style ``none``."""
    if method == "dp":
        return "dp_student" if student else "dp"
    if not student:
        return method if films else "scdp:none"
    return f"scdp_student:{SCDP_METHODS[method] if films else 'none'}"


def plan(task, checkpoints, method, planning, sets, *, noise: str = "", films: bool = True, first: int = 0,
         seed: int = SEED, film_scale: float = 1.0, student: bool = False) -> list:
    """Scored records of one method under one planner on the scenes of ``sets`` from index ``first``
    on (those before were planned at a smaller N), batched; ``noise`` names the sampler-noise stream
    ("": the start states' own); without ``films`` an SCDP method plans with style ``none`` (the
    frozen base) under its own name; ``film_scale`` scales an SCDP method's films towards the identity
    (0.5: half strength; round 2's near-margin arm). ``seed``: the scenes' (round 1: :data:`SEED`).
    With ``student`` the few-step student plans it (:func:`planner_name`), recorded under ``method``."""
    spec = planner_name(method, films, student)
    scale = {} if method == "dp" else {"film_scale": film_scale}
    planner = load_method(spec, checkpoints, task, planning, **scale)
    labelled = [(name, i, scene) for name, scenes in sets.items() for i, scene in enumerate(scenes) if i >= first]
    runs = rollout(task, planner, [s for *_, s in labelled], seeds=[scene_seed(seed, n, i) for n, i, _ in labelled],
                   noise_seeds=[scene_seed(seed, n + noise, i) for n, i, _ in labelled], progress=True,
                   desc=f"{task.name} {spec if student else method}{' ' + noise if noise else ''}{'' if films else ' films off'}"
                        f"{f' films x{film_scale:g}' if film_scale != 1 else ''}")
    cache = {}
    return [score_rollout(task, r, method=method, scene_set=n, scene_index=i, bounds=scene_bounds(task, r.goals, r.target, cache))
            for (n, i, _), r in zip(labelled, runs)]


def markdown(result: dict) -> str:
    lines = ["# The real-time gate: the fast planner (DDPM-8, warm at 4) against the default (DDPM-20, cold)", "",
             f"`{result['command']}` ({result['compute_minutes']:.1f} compute-min; matmul {result['gflops']:.0f} GFLOP/s "
             f"fp32 on this machine). Protocol: the docstring of `benchmarks/realtime_gate.py`, committed in "
             f"{result['protocol_commit']} before this run. {result['scenes']} ambiguous + {result['scenes']} clear validation "
             f"scenes per task (seed {SEED}); Δ = candidate - default; 'bound' is the one-sided 95 % scene-bootstrap "
             f"lower bound (the lower end of a {100 * ONE_SIDED_LEVEL:.0f} % interval). Success >= {GATE_MIN_SUCCESS}, "
             f"forced-style gap >= {100 * MIN_GAP_SHARE:.0f} % of the default's.", ""]
    lines += ["| arm | candidate | verdict |", "|---|---|---|"]
    for name, what in ARMS.items():
        if name in result["arms"]:
            lines.append(f"| {name} | {what} | {'PASSES' if result['arms'][name]['passes'] else 'FAILS'} |")
    lines.append("")
    if result.get("null_runs"):
        lines += ["Null check runs: " + "; ".join(f"N = {n}: {'passes' if ok else 'fails'}" for n, ok in result["null_runs"]), ""]
    for name, block in result["arms"].items():
        lines += [f"## {name}: {ARMS[name]}: {'PASSES' if block['passes'] else 'FAILS'}", ""]
        misses = failed(block)
        if misses:
            lines += ["Failed checks:", ""] + [f"- {m}" for m in misses] + [""]
        for task, t in block["tasks"].items():
            lines += [f"### {task}: {'passes' if t['passes'] else 'fails'}", "",
                      "| check | method | set | Δ mean | bound | margin | holds |", "|---|---|---|---|---|---|---|"]
            for c in t["checks"]:
                ok = "yes" if c["holds"] else "**no**"
                if c.get("missing"):
                    lines.append(f"| {c['check']} | {c.get('method', '')} | {c.get('scene_set', '')} | – | – | – | {ok} |")
                elif c["check"] == "bound":
                    lines.append(f"| {c['measure']} | {c['method']} | {c['scene_set']} | {c['mean']:+.3f} | {c['lo']:+.3f} | "
                                 f"{c['margin']:+.3f} | {ok} |")
                elif c["check"] == "success":
                    lines.append(f"| success | {c['method']} | {c['scene_set']} | {c['rate']:.3f} (default {c['default_rate']:.3f}) "
                                 f"| – | >= {GATE_MIN_SUCCESS} | {ok} |")
                else:
                    lines.append(f"| forced D̂ gap | scdp_legible - scdp_efficient | {c['scene_set']} | {c['candidate']:.3f} "
                                 f"(default {c['default']:.3f}) | {100 * c['share']:.0f} % | >= {100 * MIN_GAP_SHARE:.0f} % | {ok} |")
            lines.append("")
    return "\n".join(lines)


ARMS = {"null": "the default again, its sampler noise redrawn", "gate": "the fast planner",
        "sensitivity": "the fast planner with its films off (must fail)"}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", type=Path, default=Path("results/cpu"), help="a reproduction (its <task>/checkpoints)")
    p.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    p.add_argument("--scenes", type=int, default=SCENES, help=f"scenes per set before any doubling (protocol: {SCENES})")
    p.add_argument("--protocol-commit", default="", help="the commit that holds this protocol (for the report)")
    p.add_argument("--out", type=Path, default=Path("results/benchmarks/realtime_gate"), help="writes OUT.json and OUT.md")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    tasks = {name: get_task(name) for name in args.tasks}
    result = {"command": "python benchmarks/realtime_gate.py " + " ".join(argv if argv is not None else sys.argv[1:]),
              "protocol_commit": args.protocol_commit, "gflops": matmul_gflops(), "arms": {}, "null_runs": []}
    ck = {name: args.run / name / "checkpoints" for name in tasks}

    def every(planning, sets, **how) -> list:  # every task and method
        return [r for t in tasks for m in METHODS for r in plan(tasks[t], ck[t], m, planning, sets[t], **how)]

    default, redrawn, planned = [], [], 0
    for n in (args.scenes, 2 * args.scenes):  # the null check decides N (it doubles once, never the margins)
        sets = {name: {k: v for k, v in scene_sets(task, n, SEED, stream=VALIDATION).items() if k in (AMBIGUOUS, CLEAR)}
                for name, task in tasks.items()}  # the first scenes of a larger N are the smaller N's (same seed)
        default += every(DEFAULT, sets, first=planned)
        redrawn += every(DEFAULT, sets, first=planned, noise="/null")
        planned = n
        null = verdict(default, redrawn)
        result["null_runs"].append((n, null["passes"]))
        result["arms"]["null"], result["scenes"] = null, n
        print(f"null check at N = {n}: {'passes' if null['passes'] else 'fails'}", *failed(null), sep="\n  ", flush=True)
        if null["passes"]:
            break
    result["arms"]["gate"] = verdict(default, every(FAST, sets))
    result["arms"]["sensitivity"] = verdict(default, every(FAST, sets, films=False))
    result["informative"] = result["arms"]["null"]["passes"] and not result["arms"]["sensitivity"]["passes"]
    result["compute_minutes"] = (time.perf_counter() - t0) / 60
    write_json(args.out.with_suffix(".json"), result)
    write_text(args.out.with_suffix(".md"), markdown(result))
    print(markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
