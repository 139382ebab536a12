"""``scdp deploy``: camera -> detected blocks -> SCDP -> 1 kHz execution, in MuJoCo (:mod:`scdp.deploy`)."""

from __future__ import annotations

import numpy as np

from scdp import threads
from scdp.cli.format import style_runs
from scdp.config import PlannerSpec, PlanningOptions
from scdp.deploy import check_task, deploy_scenes
from scdp.io import atomic_path, check_output_path
from scdp.perception import Camera, ColorDetector, DepthNoise, block_reach_camera
from scdp.policies.loaders import load_method, loaded_parts
from scdp.tasks import get_task


def deploy(args) -> int:
    task = get_task(args.task)
    check_task(task)
    out = check_output_path(args.out, force=args.force)
    camera = Camera.load(args.camera) if args.camera else block_reach_camera()
    planning = PlanningOptions.from_args(args)
    planner = load_method(PlannerSpec.of(args.method), args.checkpoints, task, planning)
    threads.use_for_planning(planner.denoiser_parameters)
    seeds = range(args.scene_seed, args.scene_seed + args.scenes)
    with atomic_path(out, directory=True) as tmp:
        run = deploy_scenes(task, planner, seeds, tmp, camera=camera, detector=ColorDetector(),
                            noise=DepthNoise() if args.depth_noise else None, margin=args.margin,
                            video=not args.no_video, method=args.method, checkpoints=str(args.checkpoints),
                            command=args.command_line, parts=loaded_parts(args.checkpoints, [args.method], task, planning))
    if run.summary is None:
        r = run.results[0]
        err = np.round(np.array(r.localisation_error_m) * 1000, 1).tolist()
        print(f"{args.method}: success={r.success} steps={r.steps} styles={style_runs(r.styles)} "
              f"goal errors={err} mm limits={'ok' if not r.limit_violations else r.limit_violations} "
              f"tracking={r.tracking_error['tcp_m'] * 1000:.2f} mm overhead={r.time_overhead:+.1%} -> {out}")
    else:
        print(f"{args.method}: {run.summary['scenes']} scenes, success rate {run.summary['success_rate']:.3f}, "
              f"{len(run.failures)} perception failures, {run.summary['limit_violations']} limit violations -> {out}")
    return 0
