"""One deployed scene: camera -> detected blocks -> plan -> 1 kHz execution, in MuJoCo.

:func:`deploy_scene` runs one Block Reach scene the way the real Panda does it:

1. render the RGB-D frame of the cell's camera (:func:`scdp.perception.render_rgbd`);
2. detect the target and the distractor (any :class:`~scdp.perception.Detector`);
3. locate them in the base frame (:func:`scdp.perception.locate`);
4. plan a chunk with the chosen planner from the *executed* joint states, again after every chunk;
5. stream each chunk through Ruckig to 1 kHz and execute it on the MuJoCo arm at 1 ms
   (:mod:`scdp.execution`); success is the TCP entering the success radius of the *true* block.

The planner only ever sees the located goals. It returns a :class:`SceneResult`, whose
``to_dict()`` is the JSON record of the scene; the executed samples and the first frame that the
strip and video are drawn from travel beside it, in :class:`SceneMedia`, only when asked for.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, fields

import numpy as np

from scdp.errors import ScdpError
from scdp.execution import JerkLimitedStreamer, SimulatedPanda, limit_ratios, tracking_error, violations
from scdp.perception import Camera, DepthNoise, Detector, draw_detections, locate, paint_blocks, render_rgbd
from scdp.perception.locate import LABELS
from scdp.policies.base import Planner
from scdp.policies.control import ControlLoopPolicy
from scdp.robots import panda
from scdp.tasks import Task


@dataclass(frozen=True)
class SceneMedia:
    """What the strip and the video of a scene are drawn from (:mod:`scdp.deploy.media`)."""

    sim: SimulatedPanda  # the arm, its blocks painted
    measured: np.ndarray  # (ticks, 7) executed joint positions at 1 kHz
    first_frame: np.ndarray  # (H, W, 3) the camera's first frame, the detections drawn


@dataclass(frozen=True)
class SceneResult:
    """One deployed scene; :meth:`to_dict` is its JSON record (``deploy.json``, ``scenes/seed_K.json``)."""

    scene_seed: int
    success: bool
    time_to_success_s: float | None  # from the first command to the TCP inside the true block's radius
    goals_true: list  # (2, 3) target first, base frame [m]
    goals_detected: list  # (2, 3) as located from the camera
    localisation_error_m: list
    detections: list  # [{label, box, score}]
    styles: list  # the style of each planned chunk
    limit_ratios: dict  # the 1 kHz stream's peak / datasheet limit, per quantity
    limit_violations: list
    tracking_error: dict  # commanded vs executed: {joint_rad, tcp_m}
    waypoint_deviation_m: dict  # the 1 kHz TCP path's distance from the planned polyline: {max, mean}
    duration_s: float  # of the executed 1 kHz motion
    schedule_s: float  # of the 10 Hz plan it executes
    planning_s_per_chunk: list
    steps: int  # control steps planned
    time_overhead: float  # duration_s / schedule_s - 1
    media: SceneMedia | None = None  # with keep_samples=True only; not part of the record

    def to_dict(self) -> dict:
        return {name: getattr(self, name) for name in SCENE_KEYS}


SCENE_KEYS = tuple(f.name for f in fields(SceneResult) if f.name != "media")  # the record's keys, in order


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


def deploy_scene(task: Task, planner: Planner, scene_seed: int, *, camera: Camera, detector: Detector,
                 noise: DepthNoise | None = None, margin: float = 0.9, control: str = "torque",
                 keep_samples: bool = False) -> SceneResult:
    """Detect, plan, interpolate and execute one random Block Reach scene (drawn from ``scene_seed``).

    Raises :class:`ScdpError` when perception fails (no block, two of one label, no depth, a
    block outside the workspace): nothing is planned from a made-up goal; and (field ``actions``)
    when a planned chunk holds a NaN or inf: nothing is executed from it. With ``keep_samples``
    the result carries its :class:`SceneMedia` (the arm, the executed 1 kHz joint positions and the
    first frame with the detections drawn).
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
    policy = ControlLoopPolicy(planner, task, goals, 0, seed=scene_seed)  # the robot's control-loop interface
    policy.reset(sim.joint_positions())
    commanded, measured, plan_s, deviations = [sim.joint_positions()[None]], [sim.joint_positions()[None]], [], []
    success, steps, success_tick = False, 0, None
    while steps < task.max_episode_steps and not success:
        t0 = time.perf_counter()
        # a chunk with a NaN or inf is refused by name (ScdpError on actions): it would pass the clip to the joint
        # limits and reach the streamer. Range and speed are enforced below, as documented: waypoints are clipped
        # to the joint limits and the jerk-limited streamer takes as long as the limits ask (duration_s >=
        # schedule_s); the service, whose caller executes what it gets, refuses out-of-range and out-of-reach chunks
        planned = policy.predict_action_chunk(position=sim.tcp())
        plan_s.append(time.perf_counter() - t0)
        waypoints = np.clip(planned, panda.Q_MIN, panda.Q_MAX)[: task.max_episode_steps - steps]
        previous = policy.history[-1]
        samples = streamer.push(waypoints)
        executed = sim.follow(samples)
        tcp = panda.tcp_position(executed)
        inside = np.flatnonzero(np.linalg.norm(tcp - true_goals[0], axis=1) < task.success_radius)
        if len(inside):
            success, success_tick = True, sum(len(c) for c in commanded) - 1 + int(inside[0]) + 1
        deviations.append(polyline_distance(panda.tcp_position(samples.position), panda.tcp_position(np.vstack([previous, waypoints]))))
        commanded.append(samples.position)
        measured.append(executed)
        policy.observe(executed[samples.waypoint_index])
        steps += len(waypoints)
    stop = streamer.push(streamer.state[0][None], final=True)  # come to rest where the last command ended
    commanded.append(stop.position)
    measured.append(sim.follow(stop))
    commanded, measured = np.vstack(commanded), np.vstack(measured)
    ratios = limit_ratios(commanded, rate=streamer.rate)
    duration_s, schedule_s = (len(commanded) - 1) / streamer.rate, (steps + 1) * task.control_dt
    return SceneResult(
        scene_seed=int(scene_seed), success=bool(success),
        time_to_success_s=None if success_tick is None else success_tick / streamer.rate,
        goals_true=true_goals.tolist(), goals_detected=located.tolist(),
        localisation_error_m=np.linalg.norm(located - true_goals, axis=1).tolist(),
        detections=[{"label": d.label, "box": list(d.box), "score": round(d.score, 4)} for d in detections],
        styles=policy.styles, limit_ratios=ratios, limit_violations=violations(ratios),
        tracking_error=tracking_error(commanded, measured),
        waypoint_deviation_m={"max": float(np.max(np.concatenate(deviations))),
                              "mean": float(np.mean(np.concatenate(deviations)))},
        duration_s=duration_s, schedule_s=schedule_s, planning_s_per_chunk=plan_s, steps=steps,
        time_overhead=duration_s / schedule_s - 1.0,
        media=SceneMedia(sim, measured, draw_detections(rgb, detections)) if keep_samples else None,
    )


def check_task(task: Task) -> None:
    """Refuse a task without the camera cell: deploy drives Block Reach's Panda."""
    if task.name != "block_reach":
        raise ScdpError("--task", f"deploy drives the Panda of block_reach (the camera cell); {task.name} has none")
