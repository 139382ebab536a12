"""Deploying many scenes: the loop, what a failed scene means, the files and the pooled summary.

:func:`deploy_scenes` deploys the scenes drawn from consecutive seeds into one folder:

* ``deploy.json``: the first scene's record, with the method and the checkpoints;
* ``strip.png`` and ``deploy.mp4``: the first scene's motion seen by a person across the table, its
  TCP path traced (unless ``video=False``), and ``detections.png``, the detection camera's first frame;
* with more than one scene, ``scenes/seed_K.json`` for each and ``summary.json`` pooling them.

The failure policy: with one scene, any refusal stops the run. With several, a scene whose
*perception* refuses (no block, two of one label, no depth, a block outside the workspace) is
listed in ``summary.json``'s ``perception_failures`` and the run goes on; a refused *plan* (field
``actions``: a NaN or inf in a chunk) is the planner's fault and stops the run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from scdp.deploy.media import arm_caption, captioned, motion_frames, strip, write_mp4, write_png
from scdp.deploy.scene import SceneResult, deploy_scene
from scdp.errors import ScdpError
from scdp.io import write_json
from scdp.perception import Camera, DepthNoise, Detector
from scdp.policies.base import Planner
from scdp.tasks import Task

FRAME_EVERY_S = 0.05  # video at 20 frames per second of motion


@dataclass(frozen=True)
class DeployRun:
    """What :func:`deploy_scenes` did: each deployed scene, the refused ones, and the pooled summary
    (``None`` for a single scene)."""

    results: list[SceneResult]
    failures: list[dict]  # {scene_seed, error} of each scene whose perception refused
    summary: dict | None


def deploy_scenes(task: Task, planner: Planner, seeds: Sequence[int], folder: Path, *, camera: Camera,
                  detector: Detector, noise: DepthNoise | None = None, margin: float = 0.9, video: bool = True,
                  method: str = "", checkpoints: str = "", command: str | None = None, parts: dict | None = None) -> DeployRun:
    """Deploy one scene per seed into ``folder`` (the files and failure policy above).

    ``method`` and ``checkpoints`` name the planner in every record, with ``parts`` (each part's
    weights hash and runtime, :func:`scdp.policies.loaders.loaded_parts`); ``command`` the command
    line in the summary.
    """
    results, failures = [], []
    for i, seed in enumerate(tqdm(seeds, desc="deploy", unit="scene", disable=len(seeds) == 1)):
        media = i == 0 and video
        try:
            result = deploy_scene(task, planner, seed, camera=camera, detector=detector, noise=noise, margin=margin,
                                  keep_samples=media)
        except ScdpError as exc:
            if len(seeds) == 1 or exc.field == "actions":  # a refused plan is the planner's fault, not perception's
                raise
            failures.append({"scene_seed": seed, "error": str(exc)})
            continue
        arm = {}
        if media:
            frames = motion_frames(result.media, FRAME_EVERY_S)
            arm = {"arm_drawn": arm_caption(result.media)}
            write_png(folder / "strip.png", captioned(strip(frames), arm["arm_drawn"]))
            write_png(folder / "detections.png", captioned(result.media.first_frame, arm["arm_drawn"]))
            if not write_mp4(folder / "deploy.mp4", frames, fps=1.0 / FRAME_EVERY_S):
                print("scdp: warning: this OpenCV build cannot write MP4; strip.png only")
        record = {"method": method, "checkpoints": checkpoints, "parts": parts or {}, **arm, **result.to_dict()}
        if i == 0:
            write_json(folder / "deploy.json", record)
        if len(seeds) > 1:
            write_json(folder / "scenes" / f"seed_{seed}.json", record)
        results.append(result)
    summary = None
    if len(seeds) > 1:
        summary = {"method": method, "depth_noise": bool(noise), "command": command, **summarise(results, failures)}
        write_json(folder / "summary.json", summary)
    return DeployRun(results, failures, summary)


def summarise(results: list[SceneResult], failures: list[dict]) -> dict:
    """Pooled figures over scenes; ``failures`` are scenes whose perception refused ({scene_seed, error})."""
    n = len(results) + len(failures)
    errors = np.concatenate([r.localisation_error_m for r in results]) if results else np.zeros(0)
    worst = {k: max((r.limit_ratios[k] for r in results), default=0.0) for k in ("velocity", "acceleration", "jerk", "position")}
    plans = np.concatenate([r.planning_s_per_chunk for r in results]) if results else np.zeros(0)

    def stat(values, fn):
        return float(fn(values)) if len(values) else None

    return {
        "scenes": n, "success_rate": sum(r.success for r in results) / max(n, 1),
        "perception_failures": failures,
        "localisation_error_m": {"median": stat(errors, np.median), "max": stat(errors, np.max)},
        "limit_violations": sum(bool(r.limit_violations) for r in results), "worst_ratio": worst,
        "tracking_error_max": {"joint_rad": max((r.tracking_error["joint_rad"] for r in results), default=None),
                               "tcp_m": max((r.tracking_error["tcp_m"] for r in results), default=None)},
        "waypoint_deviation_max_m": max((r.waypoint_deviation_m["max"] for r in results), default=None),
        "time_overhead": {"mean": stat([r.time_overhead for r in results], np.mean),
                          "max": stat([r.time_overhead for r in results], np.max)},
        "planning_s_per_chunk": {"median": stat(plans, np.median), "p95": stat(plans, lambda v: np.percentile(v, 95))},
        "legible_chunk_share": stat([s == "legible" for r in results for s in r.styles], np.mean),
    }
