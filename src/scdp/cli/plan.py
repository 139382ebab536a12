"""``scdp plan``: one scene, one method, the trajectory as JSON."""

from __future__ import annotations

import time

import numpy as np

from scdp import threads
from scdp.cli.format import style_runs
from scdp.config import PlannerSpec, PlanningOptions
from scdp.evaluation.records import scene_bounds, score_rollout
from scdp.evaluation.rollout import rollout
from scdp.io import check_output_path, write_json
from scdp.policies.base import check_scene_goals
from scdp.policies.loaders import load_method
from scdp.tasks import get_task


def plan(args) -> int:
    task = get_task(args.task)
    check_output_path(args.out, force=args.force)
    spec = PlannerSpec.of(args.method, args.style)  # a style the method has no choice of is refused, not ignored
    goals = task.validate_goals(args.goals, args.target)
    t0 = time.perf_counter()
    planning = PlanningOptions.from_args(args).for_method(spec.method)  # the --profile fills what was not given
    planner = load_method(spec, args.checkpoints, task, planning)
    check_scene_goals(planner.n_goals, len(goals), "--goals")
    threads.use_for_planning(planner.denoiser_parameters)  # one scene: one thread unless the net is large (scdp.threads)
    t1 = time.perf_counter()
    (run,) = rollout(task, planner, [(goals, args.target)], seed=args.seed)
    t2 = time.perf_counter()
    record = score_rollout(task, run, method=args.method, scene_set="custom", bounds=scene_bounds(task, goals, args.target)).to_dict()
    seconds = {"loading": t1 - t0, "rollout": t2 - t1, "scoring": time.perf_counter() - t2}  # start-up: the rest of the process
    record.update(states=np.asarray(run.states).round(6).tolist(), actions=np.asarray(run.actions).round(6).tolist(),
                  planning_seconds=run.seconds, wall_seconds=seconds["rollout"], seconds=seconds, seed=args.seed,
                  chunk_starts=list(run.starts),
                  planning={k: getattr(planning, k) for k in ("profile", "sampler", "steps", "warm_skip", "runtime", "device",
                                                               "cuda_graphs")})
    write_json(args.out, record)
    m = record["metrics"]
    how = (f"{planning.profile}: {planning.sampler or 'saved sampler'}-{planning.steps or 'saved'} "
           f"warm {planning.warm_skip} {planning.runtime}")
    why = "" if run.success else f" ({run.failure or 'ended outside the success radius when the episode ran out'})"
    print(f"{args.method}: success={run.success}{why} steps={len(run.actions)} styles={style_runs(run.styles)} "
          f"d_hat={m['d_hat']:.3f} e_hat={m['e_hat']:.3f} T={m['transparency']:.3f} "
          f"planning={run.seconds:.3f}s ({how}) loading={seconds['loading']:.2f}s scoring={seconds['scoring']:.2f}s "
          f"starts={style_runs(run.starts)} -> {args.out}")
    return 0
