"""Do 1 kHz jerk-limited trajectories stay within the Panda's limits? Over many planned trajectories.

Regenerates: `results/benchmarks/execution_1khz.json`

    python benchmarks/execution_1khz.py [--checkpoints runs/cpu/block_reach/checkpoints --method scdp]
        [--trajectories 1000] [--seed 0] [--track 200] [--out results/benchmarks/execution_1khz.json]

Waypoints: with ``--checkpoints``, the joint commands of ``--method`` rolled out (10 Hz) on random
Block Reach scenes; without, the commands of generated demonstrations. Each waypoint sequence goes
through :func:`scdp.execution.interpolate` (start and end at rest); the 1 kHz output is checked by
finite differences against the datasheet velocity, acceleration and jerk limits (and the joint
range). Reported: violations, the worst ratio to each limit, the task-space deviation of the
1 kHz TCP path from the polyline through the 10 Hz waypoints, and the time overhead (1 kHz
duration over the 10 Hz schedule). The first ``--track`` trajectories are also executed on the
MuJoCo Panda at 1 ms under computed-torque control, for the tracking error.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from scdp.data.generate import generate_demos
from scdp.data.scenes import scene_seed
from scdp.deploy import polyline_distance
from scdp.evaluation.rollout import rollout
from scdp.execution import JerkLimitedStreamer, SimulatedPanda, interpolate, limit_ratios, tracking_error, violations
from scdp.io import write_json
from scdp.policies.loaders import load_method
from scdp.robots import panda
from scdp.tasks import BLOCK_REACH


def planned_waypoints(checkpoints: str, method: str, n: int, seed: int) -> list[np.ndarray]:
    planner = load_method(method, checkpoints, BLOCK_REACH)
    rng = np.random.default_rng(seed)
    scenes = []
    for _ in range(n):
        goals = BLOCK_REACH.sample_goals(rng)
        scenes.append((goals, int(rng.integers(len(goals)))))
    runs = []
    for start in tqdm(range(0, n, 100), desc=f"plan {method}", unit="100 traj"):
        runs += rollout(BLOCK_REACH, planner, scenes[start:start + 100],
                        seeds=[scene_seed(seed, "execution", i) for i in range(start, min(start + 100, n))])
    return [np.clip(np.vstack([r.states[0], r.actions]), panda.Q_MIN, panda.Q_MAX) for r in runs]


def demo_waypoints(n: int, seed: int) -> list[np.ndarray]:
    data, _ = generate_demos(BLOCK_REACH, n, seed)
    return [np.vstack([ep["state"][:1], ep["action"]]) for ep in (data.episode(i) for i in range(n))]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--checkpoints")
    ap.add_argument("--method", default="scdp")
    ap.add_argument("--trajectories", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--track", type=int, default=200)
    ap.add_argument("--out", type=Path, default=Path("results/benchmarks/execution_1khz.json"))
    args = ap.parse_args()
    start = time.perf_counter()
    if args.checkpoints:
        source = {"kind": "planned", "method": args.method, "checkpoints": args.checkpoints}
        waypoint_sets = planned_waypoints(args.checkpoints, args.method, args.trajectories, args.seed)
    else:
        source = {"kind": "generator demos"}
        waypoint_sets = demo_waypoints(args.trajectories, args.seed)
    step = BLOCK_REACH.control_dt
    worst = {"velocity": 0.0, "acceleration": 0.0, "jerk": 0.0, "position": 0.0}
    broken, deviation, overhead, tracking = 0, [], [], []
    for i, w in enumerate(tqdm(waypoint_sets, desc="1 kHz", unit="traj")):
        q = interpolate(w, step=step)
        ratios = limit_ratios(q)
        broken += bool(violations(ratios))
        worst = {k: max(worst[k], ratios[k]) for k in worst}
        deviation.append(float(np.max(polyline_distance(panda.tcp_position(q), panda.tcp_position(w)))))
        overhead.append((len(q) - 1) / 1000.0 / ((len(w) - 1) * step) - 1.0)
        if i < args.track:
            sim = SimulatedPanda(np.array([[0.5, 0.1, 0.1], [0.5, -0.1, 0.1]]), w[0])
            samples = JerkLimitedStreamer(w[0], step=step).push(w[1:], final=True)
            tracking.append(tracking_error(samples.position, sim.follow(samples)))
    report = {
        "trajectories": len(waypoint_sets), "waypoints": source, "violations": broken, "worst_ratio": worst,
        "waypoint_deviation_m": {"median": float(np.median(deviation)), "max": float(np.max(deviation))},
        "time_overhead": {"median": float(np.median(overhead)), "mean": float(np.mean(overhead)), "max": float(np.max(overhead))},
        "tracking_error": {"trajectories": len(tracking), "max_joint_rad": max(t["joint_rad"] for t in tracking),
                           "max_tcp_m": max(t["tcp_m"] for t in tracking)},
        "planning_margin": 0.9, "rate_hz": 1000, "step_s": step,
        "command": "python benchmarks/execution_1khz.py"
                   + (f" --checkpoints {args.checkpoints} --method {args.method}" if args.checkpoints else "")
                   + f" --trajectories {args.trajectories} --seed {args.seed} --track {args.track}",
        "compute_minutes": round((time.perf_counter() - start) / 60, 2),
    }
    write_json(args.out, report)
    print(json.dumps({k: report[k] for k in ("trajectories", "violations", "worst_ratio", "time_overhead")}))


if __name__ == "__main__":
    main()
