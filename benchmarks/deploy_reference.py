"""Why does a deployment fail where an evaluation succeeds? The same scenes, planner and noise in the 10 Hz env.

Regenerates: `results/deploy/reference.json`

    python benchmarks/deploy_reference.py --deploy results/deploy --checkpoints DIR [--out results/deploy/reference.json]

For each scene of a ``scdp deploy --scenes N`` output, rolls the same method out in the 10 Hz
Block Reach environment (its default ``tracking="exact"``, as the demonstrations are recorded) on
the goals the camera located, with the scene's seed for the sampler, and pairs the outcome with the
deployment (1 kHz Ruckig interpolation, computed-torque tracking within a millimetre). Also rolls it
out with the environment's states replaced by the commanded states. With exact tracking the two
10 Hz rollouts agree; a planner trained on demos recorded through lagging servos
(``tracking="servo"``) fails the second one, which is how the deployment shortfall of such a
planner was traced to the servo's lag rather than to the interpolation or the perception.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch
from tqdm.auto import tqdm

from scdp.evaluation.statistics import bootstrap_interval
from scdp.io import write_json
from scdp.policies.base import observe_histories
from scdp.policies.loaders import load_method
from scdp.tasks import BLOCK_REACH as TASK


def episode(planner, goals, seed: int, observe_commands: bool) -> bool:
    env = TASK.make_env()
    obs, _ = env.reset(seed=seed, options={"goals": goals, "target": 0})
    history, generator, steps = [obs["state"]], torch.Generator().manual_seed(seed), 0
    planner.reset()
    while steps < TASK.max_episode_steps:
        o = observe_histories(TASK, [history], [env.goals], [0], planner.n_obs_steps, [env.position])
        actions = planner.act(o, [generator])[0][0].double().numpy()
        for a in actions:
            obs, _, terminated, truncated, info = env.step(a)
            history.append(a if observe_commands else obs["state"])
            steps += 1
            if terminated or truncated:
                return bool(info["success"])
    return False


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--deploy", type=Path, default=Path("results/deploy"))
    ap.add_argument("--checkpoints", required=True)
    ap.add_argument("--out", type=Path, default=Path("results/deploy/reference.json"))
    args = ap.parse_args()
    summary = json.loads((args.deploy / "summary.json").read_text())
    scenes = [json.loads(p.read_text()) for p in sorted((args.deploy / "scenes").glob("seed_*.json"))]
    planner = load_method(summary["method"], args.checkpoints, TASK)
    deployed, env10, commanded = [], [], []
    for s in tqdm(scenes, unit="scene"):
        goals = TASK.validate_goals(np.array(s["goals_detected"])[:, :2], 0)
        deployed.append(float(s["success"]))
        env10.append(float(episode(planner, goals, s["scene_seed"], observe_commands=False)))
        commanded.append(float(episode(planner, goals, s["scene_seed"], observe_commands=True)))
    d = np.array(env10) - np.array(deployed)
    low, high = bootstrap_interval(d)
    diff = {"mean": float(d.mean()), "ci95": [low, high], "holds": bool(low > 0)}
    report = {"scenes": len(scenes), "method": summary["method"], "checkpoints": args.checkpoints,
              "success_rate": {"deploy_1khz": float(np.mean(deployed)), "env_10hz": float(np.mean(env10)),
                               "env_10hz_observing_commands": float(np.mean(commanded))},
              "env_minus_deploy": diff,
              "command": f"python benchmarks/deploy_reference.py --deploy {args.deploy} --checkpoints {args.checkpoints}"}
    write_json(args.out, report)
    print(json.dumps(report["success_rate"]), json.dumps(diff))


if __name__ == "__main__":
    main()
