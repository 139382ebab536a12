"""``scdp deploy``: camera -> detected blocks -> SCDP -> 1 kHz execution, in MuJoCo."""

from __future__ import annotations

import numpy as np
from tqdm.auto import tqdm

from scdp import threads
from scdp.cli.plan import style_runs
from scdp.config import PlannerSpec, PlanningOptions
from scdp.errors import ScdpError
from scdp.io import atomic_path, check_output_path, write_json
from scdp.perception import Camera, ColorDetector, DepthNoise, block_reach_camera
from scdp.pipeline.deploy import check_task, deploy_scene, motion_frames, strip, summarise, write_mp4, write_png
from scdp.policies.loaders import load_method, network_parameters
from scdp.tasks import get_task

FRAME_EVERY_S = 0.05  # video at 20 frames per second of motion


def public(result: dict) -> dict:
    return {k: v for k, v in result.items() if not k.startswith("_")}


def deploy(args) -> int:
    task = get_task(args.task)
    check_task(task)
    out = check_output_path(args.out, force=args.force)
    if args.scene_seed < 0:
        raise ScdpError("--scene-seed", f"must be >= 0, got {args.scene_seed}")
    if not 0 < args.margin <= 1:
        raise ScdpError("--margin", f"must be in (0, 1], got {args.margin}")
    camera = Camera.load(args.camera) if args.camera else block_reach_camera()
    planner = load_method(PlannerSpec.of(args.method), args.checkpoints, task, PlanningOptions.from_args(args))
    threads.use_for_planning(network_parameters(planner))
    detector, noise = ColorDetector(), DepthNoise() if args.depth_noise else None
    seeds = range(args.scene_seed, args.scene_seed + args.scenes)
    results, failures = [], []
    with atomic_path(out, directory=True) as tmp:
        for i, seed in enumerate(tqdm(seeds, desc="deploy", unit="scene", disable=len(seeds) == 1)):
            media = i == 0 and not args.no_video
            try:
                result = deploy_scene(task, planner, seed, camera=camera, detector=detector, noise=noise, margin=args.margin,
                                      keep_samples=media)
            except ScdpError as exc:
                if len(seeds) == 1 or exc.field == "actions":  # a refused plan is the planner's fault, not perception's
                    raise
                failures.append({"scene_seed": seed, "error": str(exc)})
                continue
            if media:
                frames = motion_frames(result, camera, FRAME_EVERY_S)
                write_png(tmp / "strip.png", strip(frames))
                if not write_mp4(tmp / "deploy.mp4", frames, fps=1.0 / FRAME_EVERY_S):
                    print("scdp: warning: this OpenCV build cannot write MP4; strip.png only")
            record = {"method": args.method, "checkpoints": str(args.checkpoints), **public(result)}
            if i == 0:
                write_json(tmp / "deploy.json", record)
            if len(seeds) > 1:
                write_json(tmp / "scenes" / f"seed_{seed}.json", record)
            results.append(result)
        if len(seeds) > 1:
            summary = {"method": args.method, "depth_noise": bool(noise), "command": args.command_line,
                       **summarise([public(r) for r in results], failures)}
            write_json(tmp / "summary.json", summary)
    if len(seeds) == 1:
        r = results[0]
        err = np.round(np.array(r["localisation_error_m"]) * 1000, 1).tolist()
        print(f"{args.method}: success={r['success']} steps={r['steps']} styles={style_runs(r['styles'])} "
              f"goal errors={err} mm limits={'ok' if not r['limit_violations'] else r['limit_violations']} "
              f"tracking={r['tracking_error']['tcp_m'] * 1000:.2f} mm overhead={r['time_overhead']:+.1%} -> {out}")
    else:
        print(f"{args.method}: {summary['scenes']} scenes, success rate {summary['success_rate']:.3f}, "
              f"{len(failures)} perception failures, {summary['limit_violations']} limit violations -> {out}")
    return 0
