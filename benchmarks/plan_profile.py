"""Where planning time goes: network, scheduler, environment stepping, the rest (Python and tensor glue).

Regenerates: `results/benchmarks/plan_profile*.md`

    python benchmarks/plan_profile.py --checkpoints results/cpu/navigation/checkpoints [--task navigation] \
        [--method scdp] [--scenes 10] [--out results/benchmarks/plan_profile]

Rolls ``--method`` out at batch 1 over ``--scenes`` random scenes under Python's ``cProfile`` and
splits the wall time by the cumulative time of a few functions:

* ``network``: every call of the denoising U-Net (``ConditionalUnet1D.forward``, or the exported graph's
  ``OnnxDenoiser.forward`` with ``--runtime onnx``);
* ``scheduler``: DDPM's and DDIM's steps (:class:`scdp.policies.ddpm_steps.DDPMSteps`,
  :class:`scdp.policies.ddim_steps.DDIMSteps`), diffusers' DDIM and DPM-Solver ``step`` and ``set_timesteps``;
* ``style``: the films (scene encoder and style predictors, SCDP only) and the arbitration;
* ``environment``: the Gymnasium environment's ``step`` and ``reset``;
* ``rest``: everything else in the rollout (observation building, normalisation, per-op Python).

The profiler's own overhead inflates Python-heavy parts, so the absolute numbers are above the
unprofiled ones (also recorded: the same rollout without the profiler); the shares are what this
is for. Run it alone on the machine. Writes ``OUT.json`` and ``OUT.md``.
"""

from __future__ import annotations

import argparse
import cProfile
import inspect
import pstats
import shutil
import tempfile
import time
from pathlib import Path

import torch
from diffusers import DDIMScheduler, DPMSolverMultistepScheduler
from realtime import matmul_gflops  # a sibling benchmark

import scdp  # noqa: F401  - first, so that torch loads under scdp's thread policy, as in real use
from scdp import threads
from scdp.cli import main as scdp_main
from scdp.config import PlannerSpec, PlanningOptions
from scdp.data.scenes import BENCHMARK, sample_scenes
from scdp.envs.base import GoalReachEnv
from scdp.evaluation.rollout import rollout
from scdp.io import write_json, write_text
from scdp.keys import TASK_NAMES
from scdp.models.unet1d import ConditionalUnet1D
from scdp.policies.checkpoint import ONNX_META
from scdp.policies.ddim_steps import DDIMSteps
from scdp.policies.ddpm_steps import DDPMSteps
from scdp.policies.exported import OnnxDenoiser
from scdp.policies.loaders import load_method
from scdp.policies.scdp import StyleConditionedPolicy
from scdp.tasks import get_task

# part -> the functions whose cumulative time it is (none of them calls another of its part)
PARTS = {
    "network": [ConditionalUnet1D.forward, OnnxDenoiser.forward],
    "scheduler": [DDPMSteps.step, DDIMSteps.step, DDIMScheduler.step, DPMSolverMultistepScheduler.step,
                  DDIMScheduler.set_timesteps, DPMSolverMultistepScheduler.set_timesteps],
    "style": [StyleConditionedPolicy.film, StyleConditionedPolicy.legible_weights],  # films; the arbitration
    "environment": [GoalReachEnv.step, GoalReachEnv.reset],
}


def cumulative(stats: pstats.Stats, functions: list) -> float:
    """Sum of the cumulative seconds of ``functions`` (matched by their code object) in ``stats``."""
    code = [inspect.unwrap(f).__code__ for f in functions]  # a decorator's wrapper (torch.no_grad) is shared
    keys = {(c.co_filename, c.co_firstlineno, c.co_name) for c in code}
    return sum(entry[3] for key, entry in stats.stats.items() if key in keys)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--checkpoints", required=True, type=Path, help="a task's checkpoints folder")
    ap.add_argument("--task", default="navigation", choices=list(TASK_NAMES))
    ap.add_argument("--method", default="scdp", help="planner name, as in scdp plan --method (default scdp)")
    ap.add_argument("--scenes", type=int, default=10, help="random scenes, rolled out one at a time (default 10)")
    ap.add_argument("--runtime", default=None, choices=["torch", "onnx", "auto"],
                    help="the denoiser's runtime (default: the --profile's); onnx exports a temporary copy of the "
                         "checkpoints first")
    ap.add_argument("--profile", default="trained", choices=["trained", "realtime"],
                    help="what the options left unset plan with (scdp.config.PlanningOptions; default trained)")
    ap.add_argument("--sampler", default=None, help="planning-time sampler (default: the --profile's)")
    ap.add_argument("--steps", type=int, default=None, help="denoising steps (default: the --profile's)")
    ap.add_argument("--warm-skip", type=int, default=None, help="warm start step (default: the --profile's)")
    ap.add_argument("--out", type=Path, default=Path("results/benchmarks/plan_profile"))
    args = ap.parse_args()
    gflops = matmul_gflops()  # the machine's rate on every core, before planning takes its threads
    threads.use_for_planning()
    task = get_task(args.task)
    checkpoints = args.checkpoints
    if args.runtime == "onnx" and not (args.checkpoints / "base" / ONNX_META).is_file():
        checkpoints = Path(tempfile.mkdtemp(prefix="scdp-profile-")) / "checkpoints"
        shutil.copytree(args.checkpoints, checkpoints)
        assert scdp_main(["export", "--task", task.name, str(checkpoints)]) == 0
    planning = PlanningOptions(runtime=args.runtime, profile=args.profile, sampler=args.sampler, steps=args.steps,
                               warm_skip=args.warm_skip)
    planner = load_method(args.method, checkpoints, task, planning)
    planning = planning.for_method(PlannerSpec.parse(args.method).method)  # what it plans with, for the record
    scenes = sample_scenes(task, args.scenes, seed=7, stream=BENCHMARK)

    def run():
        with torch.inference_mode():
            for i, scene in enumerate(scenes):
                rollout(task, planner, [scene], seed=i)

    run()  # warm-up: first calls allocate and load kernels
    t0 = time.perf_counter()
    run()
    plain = time.perf_counter() - t0
    profiler = cProfile.Profile()
    t0 = time.perf_counter()
    profiler.runcall(run)
    profiled = time.perf_counter() - t0
    stats = pstats.Stats(profiler)
    parts = {name: cumulative(stats, wanted) for name, wanted in PARTS.items()}
    parts["rest"] = max(profiled - sum(parts.values()), 0.0)
    base = planner if hasattr(planner, "config") else getattr(planner, "base", getattr(planner, "policy", None))
    flags = " ".join(f"--{k.replace('_', '-')} {v}" for k, v in (("profile", args.profile), ("sampler", args.sampler),
                     ("steps", args.steps), ("warm_skip", args.warm_skip), ("runtime", args.runtime)) if v is not None)
    report = {"task": args.task, "method": args.method, "runtime": planning.runtime, "scenes": args.scenes,
              "threads": torch.get_num_threads(), "sampler": base.config.sampler, "steps": base.config.num_inference_steps,
              "warm_skip": planning.warm_skip, "profile": args.profile, "gflops": gflops,
              "seconds_unprofiled": plain, "seconds_profiled": profiled,
              "seconds_per_trajectory_unprofiled": plain / args.scenes,
              "parts_s": parts, "shares": {k: v / profiled for k, v in parts.items()},
              "command": f"python benchmarks/plan_profile.py --checkpoints {args.checkpoints} --task {args.task} "
                         f"--method {args.method} --scenes {args.scenes} {flags} --out {args.out}"}
    per = 1000 * plain / args.scenes  # unprofiled ms per trajectory, split by the profiled shares
    rows = "\n".join(f"| {k} | {v:.3f} | {report['shares'][k]:.1%} | {per * report['shares'][k]:.1f} |" for k, v in parts.items())
    write_json(args.out.with_suffix(".json"), report)
    write_text(args.out.with_suffix(".md"),
               f"# Where planning time goes ({args.task}, {args.method}, {planning.runtime}, batch 1)\n\n`{report['command']}`\n\n"
               f"{args.scenes} trajectories, {report['sampler']}-{report['steps']} warm-started at step {planning.warm_skip}, "
               f"{report['threads']} thread(s), the machine at {gflops:.0f} GFLOP/s fp32 matmul: "
               f"{plain:.2f} s unprofiled ({plain / args.scenes:.3f} s per trajectory), "
               f"{profiled:.2f} s under cProfile. The last column splits the unprofiled time per trajectory by the "
               f"profiled shares (the profiler inflates Python-heavy parts, so it overstates them).\n\n"
               f"| part | seconds (profiled) | share | ms per trajectory (unprofiled, by share) |\n|---|---|---|---|\n{rows}\n")
    print(rows)


if __name__ == "__main__":
    main()
