"""The paper's robot path, in simulation: camera -> detected blocks -> plan -> 1 kHz execution.

:func:`deploy_scene` runs one Block Reach scene the way the real Panda does it:

1. render the RGB-D frame of the cell's camera (:func:`scdp.perception.render_rgbd`);
2. detect the target and the distractor (any :class:`~scdp.perception.Detector`);
3. locate them in the base frame (:func:`scdp.perception.locate`);
4. plan a chunk with the chosen planner from the *executed* joint states, again after every chunk;
5. stream each chunk through Ruckig to 1 kHz and execute it on the MuJoCo arm at 1 ms
   (:mod:`scdp.execution`); success is the TCP entering the success radius of the *true* block.

The planner only ever sees the located goals. What it returns is a JSON-ready dict
(:data:`SCENE_KEYS`); :func:`summarise` pools many scenes. Swapping the simulated camera and arm
for real ones means implementing :class:`~scdp.execution.Arm` and a ``capture()`` that returns
``(rgb, depth)`` (docs/deploy.md).
"""

from __future__ import annotations

import time

import cv2
import numpy as np
import torch

from scdp.errors import ScdpError
from scdp.execution import JerkLimitedStreamer, SimulatedPanda, limit_ratios, tracking_error, violations
from scdp.perception import Camera, DepthNoise, Detector, draw_detections, locate, paint_blocks, render_rgbd
from scdp.perception.locate import LABELS
from scdp.policies.base import Planner, observe_histories
from scdp.robots import panda

SCENE_KEYS = ("scene_seed", "success", "goals_true", "goals_detected", "localisation_error_m", "detections", "styles",
              "limit_ratios", "limit_violations", "tracking_error", "waypoint_deviation_m", "duration_s", "schedule_s",
              "time_overhead", "planning_s_per_chunk", "steps")


def polyline_distance(points: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """Distance of each point (M, 3) to the polyline through ``vertices`` (N, 3). (M,)."""
    if len(vertices) == 1:
        return np.linalg.norm(points - vertices[0], axis=1)
    a, b = vertices[:-1], vertices[1:]  # (N-1, 3) segments
    ab = b - a
    t = np.einsum("msk,sk->ms", points[:, None] - a[None], ab) / np.maximum(np.einsum("sk,sk->s", ab, ab), 1e-18)
    closest = a[None] + np.clip(t, 0, 1)[..., None] * ab[None]
    return np.min(np.linalg.norm(points[:, None] - closest, axis=-1), axis=1)


def perceive(sim: SimulatedPanda, camera: Camera, detector: Detector, noise: DepthNoise | None, seed: int):
    """(rgb, detections, located goals (2, 3) in LABELS order) of the arm's scene."""
    rgb, depth = render_rgbd(sim, camera, noise=noise, rng=np.random.default_rng(seed) if noise else None)
    detections = detector.detect(rgb)
    return rgb, detections, locate(detections, depth, camera, labels=LABELS)


def deploy_scene(task, planner: Planner, scene_seed: int, *, camera: Camera, detector: Detector,
                 noise: DepthNoise | None = None, margin: float = 0.9, control: str = "torque",
                 keep_samples: bool = False) -> dict:
    """Detect, plan, interpolate and execute one random Block Reach scene (drawn from ``scene_seed``).

    Raises :class:`ScdpError` when perception fails (no block, two of one label, no depth, a
    block outside the workspace): nothing is planned from a made-up goal; and (field ``actions``)
    when a planned chunk holds a NaN or inf: nothing is executed from it. With ``keep_samples``
    the result also holds the executed 1 kHz joint positions (``"_measured"``), the first frame with
    the detections drawn (``"_first_frame"``) and the simulated arm (``"_sim"``).
    """
    env = task.make_env()
    env.reset(seed=scene_seed)
    order = [env.target] + [k for k in range(len(env.goals)) if k != env.target]  # target first, as LABELS
    true_goals = env.goals[order]
    sim = SimulatedPanda(env.goals, env.state, control=control)
    paint_blocks(sim.model, env.target, len(env.goals))
    rgb, detections, located = perceive(sim, camera, detector, noise, scene_seed)
    goals = task.validate_goals(located[:, :2], 0, field="detections")  # blocks rest on the table: (x, y) + block height

    streamer = JerkLimitedStreamer(sim.joint_positions(), step=task.control_dt, margin=margin)
    generator = torch.Generator().manual_seed(scene_seed)
    history = [sim.joint_positions()]
    commanded, measured, styles, plan_s, deviations = [sim.joint_positions()[None]], [sim.joint_positions()[None]], [], [], []
    planner.reset()
    success, steps, success_tick = False, 0, None
    while steps < task.max_episode_steps and not success:
        obs = observe_histories(task, [history], [goals], [0], planner.n_obs_steps, [sim.tcp()])
        t0 = time.perf_counter()
        actions, chunk_styles = planner.act(obs, [generator])
        plan_s.append(time.perf_counter() - t0)
        styles.append(chunk_styles[0])
        # a chunk with a NaN or inf is refused by name: it would pass the clip to the joint limits and reach the
        # streamer. Range and speed are enforced below, as documented: waypoints are clipped to the joint limits
        # and the jerk-limited streamer takes as long as the limits ask (duration_s >= schedule_s); the service,
        # whose caller executes what it gets, refuses out-of-range and out-of-reach chunks instead
        planned = actions[0].double().numpy()
        if not np.all(np.isfinite(planned)):
            k = int(np.argmin(np.isfinite(planned).all(axis=1)))
            raise ScdpError("actions", f"step {k} of the chunk planned at step {steps} contains NaN or inf; "
                                       "nothing was executed")
        waypoints = np.clip(planned, panda.Q_MIN, panda.Q_MAX)[: task.max_episode_steps - steps]
        previous = history[-1]
        samples = streamer.push(waypoints)
        executed = sim.follow(samples)
        tcp = panda.tcp_position(executed)
        inside = np.flatnonzero(np.linalg.norm(tcp - true_goals[0], axis=1) < task.success_radius)
        if len(inside):
            success, success_tick = True, sum(len(c) for c in commanded) - 1 + int(inside[0]) + 1
        deviations.append(polyline_distance(panda.tcp_position(samples.position), panda.tcp_position(np.vstack([previous, waypoints]))))
        commanded.append(samples.position)
        measured.append(executed)
        history.extend(executed[samples.waypoint_index])
        steps += len(waypoints)
    stop = streamer.push(streamer.state[0][None], final=True)  # come to rest where the last command ended
    commanded.append(stop.position)
    measured.append(sim.follow(stop))
    commanded, measured = np.vstack(commanded), np.vstack(measured)
    ratios = limit_ratios(commanded, rate=streamer.rate)
    result = {
        "scene_seed": int(scene_seed), "success": bool(success),
        "time_to_success_s": None if success_tick is None else success_tick / streamer.rate,
        "goals_true": true_goals.tolist(), "goals_detected": located.tolist(),
        "localisation_error_m": np.linalg.norm(located - true_goals, axis=1).tolist(),
        "detections": [{"label": d.label, "box": list(d.box), "score": round(d.score, 4)} for d in detections],
        "styles": styles, "limit_ratios": ratios, "limit_violations": violations(ratios),
        "tracking_error": tracking_error(commanded, measured),
        "waypoint_deviation_m": {"max": float(np.max(np.concatenate(deviations))),
                                 "mean": float(np.mean(np.concatenate(deviations)))},
        "duration_s": (len(commanded) - 1) / streamer.rate, "schedule_s": (steps + 1) * task.control_dt,
        "planning_s_per_chunk": plan_s, "steps": steps,
    }
    result["time_overhead"] = result["duration_s"] / result["schedule_s"] - 1.0
    if keep_samples:
        result["_measured"], result["_first_frame"], result["_sim"] = measured, draw_detections(rgb, detections), sim
    return result


def summarise(results: list[dict], failures: list[dict]) -> dict:
    """Pooled figures over scenes; ``failures`` are scenes whose perception refused ({seed, error})."""
    n = len(results) + len(failures)
    errors = np.concatenate([r["localisation_error_m"] for r in results]) if results else np.zeros(0)
    worst = {k: max((r["limit_ratios"][k] for r in results), default=0.0) for k in ("velocity", "acceleration", "jerk", "position")}
    plans = np.concatenate([r["planning_s_per_chunk"] for r in results]) if results else np.zeros(0)

    def stat(values, fn):
        return float(fn(values)) if len(values) else None

    return {
        "scenes": n, "success_rate": sum(r["success"] for r in results) / max(n, 1),
        "perception_failures": failures,
        "localisation_error_m": {"median": stat(errors, np.median), "max": stat(errors, np.max)},
        "limit_violations": sum(bool(r["limit_violations"]) for r in results), "worst_ratio": worst,
        "tracking_error_max": {"joint_rad": max((r["tracking_error"]["joint_rad"] for r in results), default=None),
                               "tcp_m": max((r["tracking_error"]["tcp_m"] for r in results), default=None)},
        "waypoint_deviation_max_m": max((r["waypoint_deviation_m"]["max"] for r in results), default=None),
        "time_overhead": {"mean": stat([r["time_overhead"] for r in results], np.mean),
                          "max": stat([r["time_overhead"] for r in results], np.max)},
        "planning_s_per_chunk": {"median": stat(plans, np.median), "p95": stat(plans, lambda v: np.percentile(v, 95))},
        "legible_chunk_share": stat([s == "legible" for r in results for s in r["styles"]], np.mean),
    }


def check_task(task) -> None:
    if task.name != "block_reach":
        raise ScdpError("--task", f"deploy drives the Panda of block_reach (the camera cell); {task.name} has none")


def motion_frames(result: dict, camera: Camera, every_s: float) -> list[np.ndarray]:
    """Camera frames of a kept deployment (``keep_samples=True``), one per ``every_s`` seconds of
    motion, the detections drawn on the first."""
    sim, measured = result["_sim"], result["_measured"]
    ticks = np.unique(np.append(np.arange(0, len(measured), max(1, round(every_s * sim.rate))), len(measured) - 1))
    frames = [result["_first_frame"]]
    for t in ticks[1:]:
        sim.data.qpos[:7] = measured[t]
        frames.append(render_rgbd(sim, camera)[0])
    return frames


def strip(frames: list[np.ndarray], count: int = 5, scale: float = 0.5) -> np.ndarray:
    """``count`` frames evenly along the motion side by side (the paper's real-robot figure)."""
    picks = np.linspace(0, len(frames) - 1, min(count, len(frames))).round().astype(int)
    small = [cv2.resize(frames[i], None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) for i in picks]
    return cv2.hconcat(small)


def write_png(path, rgb: np.ndarray) -> None:
    ok, data = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    if not ok:
        raise ScdpError("--out", f"could not encode {path}")
    with open(path, "wb") as f:
        f.write(data.tobytes())


def write_mp4(path, frames: list[np.ndarray], fps: float) -> bool:
    """MP4 (MPEG-4 part 2) through OpenCV's FFmpeg backend; False where this OpenCV cannot write one."""
    h, w = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
    if not writer.isOpened():
        return False
    for f in frames:
        writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    writer.release()
    return True
