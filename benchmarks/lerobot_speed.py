"""scdp's denoising loop beside LeRobot's, on the same U-Net size, one machine, one time window (issue 79).

Regenerates: `results/benchmarks/lerobot_speed.md`

    LEROBOT_PYTHON=/tmp/lerobot311/bin/python python benchmarks/lerobot_speed.py --out results/benchmarks/lerobot_speed

Two environments, one script. Run plainly, it is the driver: it times scdp here and runs itself as
``LEROBOT_PYTHON benchmarks/lerobot_speed.py lerobot`` in LeRobot's own venv (the recipe:
``benchmarks/lerobot_check.py``), which never imports scdp. The two sides take turns, ``--rounds``
times, and the medians are reported.

Both sides plan one cold chunk for one scene (batch 1), with diffusers' DDIM at 10 and 8 steps and
DDPM at 100 steps, at 1 and 2 torch threads. Both use the cpu preset's U-Net shape: down dims 32-64-128,
kernel 5, 8 groups, a 64-wide step embedding, horizon 16, 2 observed steps, 8 actions, a 3-D state.
LeRobot's policy conditions on the state and a 2-D environment state (the goal). Its weights are
random and seeded: the time does not depend on them. scdp's is the committed Navigation DP, in torch.

Each side reports two times: the chunk (scdp: ``DiffusionPolicy.act``, with its observation;
LeRobot: ``DiffusionModel.generate_actions``) and one U-Net call. Their difference, divided by the
steps, is the loop's own cost per step. LeRobot's side runs in the environment the driver was started
with, not the one scdp gives itself (``OMP_WAIT_POLICY=PASSIVE``, :mod:`scdp.threads`): each side as its
users run it. LeRobot's torchvision is the CUDA build beside torch+cpu, so its compiled ops are declared
by lerobot_check's shim; the state-only policy never uses them.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

USER_ENV = dict(os.environ)  # before scdp is imported: scdp sets OMP_WAIT_POLICY=PASSIVE for itself (scdp.threads)
SAMPLERS = (("ddim", 10), ("ddim", 8), ("ddpm", 100))
THREADS = (1, 2)
REPEATS = {10: 40, 8: 40, 100: 6}  # chunks timed per setting (after two warm-up chunks)
SHAPE = {"down_dims": (32, 64, 128), "kernel_size": 5, "n_groups": 8, "step_embed": 64, "horizon": 16,
         "n_obs_steps": 2, "n_action_steps": 8, "state": 3, "goal": 2}


def _timed(fn, repeats: int) -> float:
    for _ in range(2):
        fn()
    t0 = time.perf_counter()
    for _ in range(repeats):
        fn()
    return 1000 * (time.perf_counter() - t0) / repeats


def lerobot_side() -> dict:
    """Runs in LeRobot's venv: its DiffusionPolicy of the same shape, its own loop."""
    import lerobot_check  # noqa: F401 - its torchvision shim, before lerobot imports torchvision
    import torch
    from diffusers import DDIMScheduler, DDPMScheduler
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.diffusion.configuration_diffusion import DiffusionConfig
    from lerobot.policies.diffusion.modeling_diffusion import DiffusionPolicy

    torch.manual_seed(0)
    s = SHAPE
    cfg = DiffusionConfig(
        n_obs_steps=s["n_obs_steps"], horizon=s["horizon"], n_action_steps=s["n_action_steps"], down_dims=s["down_dims"],
        kernel_size=s["kernel_size"], n_groups=s["n_groups"], diffusion_step_embed_dim=s["step_embed"],
        num_train_timesteps=100, beta_schedule="squaredcos_cap_v2", device="cpu",
        input_features={"observation.state": PolicyFeature(type=FeatureType.STATE, shape=(s["state"],)),
                        "observation.environment_state": PolicyFeature(type=FeatureType.ENV, shape=(s["goal"],))},
        output_features={"action": PolicyFeature(type=FeatureType.ACTION, shape=(s["state"],))})
    model = DiffusionPolicy(cfg).eval().diffusion
    batch = {"observation.state": torch.randn(1, s["n_obs_steps"], s["state"]),
             "observation.environment_state": torch.randn(1, s["n_obs_steps"], s["goal"])}
    x, k = torch.randn(1, s["horizon"], s["state"]), torch.tensor([5])
    cond = torch.randn(1, (s["state"] + s["goal"]) * s["n_obs_steps"])
    out = {"parameters": sum(p.numel() for p in model.unet.parameters()), "torch": torch.__version__, "rows": []}
    for threads in THREADS:
        torch.set_num_threads(threads)
        with torch.inference_mode():
            unet_ms = _timed(lambda: model.unet(x, k, global_cond=cond), 200)
            for sampler, steps in SAMPLERS:
                kind = DDIMScheduler if sampler == "ddim" else DDPMScheduler
                model.noise_scheduler = kind(num_train_timesteps=100, beta_schedule="squaredcos_cap_v2", clip_sample=True,
                                             prediction_type="epsilon")
                model.num_inference_steps = steps
                chunk = _timed(lambda: model.generate_actions(batch), REPEATS[steps])
                out["rows"].append({"threads": threads, "sampler": sampler, "steps": steps, "chunk_ms": chunk, "unet_ms": unet_ms})
    return out


def scdp_side(checkpoints: Path) -> dict:
    """Runs here: scdp's committed Navigation DP in torch, one cold chunk through ``act``."""
    import numpy as np
    import torch

    from scdp.config import PlanningOptions
    from scdp.policies.base import observe_histories
    from scdp.policies.loaders import load_method
    from scdp.tasks import get_task

    task = get_task("navigation")
    obs = observe_histories(task, [np.array([task.nominal_start()])], np.array([[[2.0, 0.3], [2.0, -0.3]]]), [0], 2)
    out = {"torch": torch.__version__, "rows": []}
    for threads in THREADS:
        torch.set_num_threads(threads)
        for sampler, steps in SAMPLERS:
            policy = load_method("dp", checkpoints, task, PlanningOptions(sampler=sampler, steps=steps, runtime="torch"))
            out["parameters"] = policy.denoiser_parameters
            x, k = torch.randn(1, SHAPE["horizon"], SHAPE["state"]), torch.tensor([5])
            cond = policy.observe(obs.state_hist, obs.goal)
            generator = torch.Generator().manual_seed(0)
            with torch.inference_mode():
                unet_ms = _timed(lambda p=policy, x=x, k=k, c=cond: p.unet(x, k, c), 200)
                chunk = _timed(lambda p=policy, g=generator: p.act(obs, [g]), REPEATS[steps])
            out["rows"].append({"threads": threads, "sampler": sampler, "steps": steps, "chunk_ms": chunk, "unet_ms": unet_ms})
    return out


def median_rows(runs: list[dict]) -> list[dict]:
    """Each setting's median chunk and U-Net time over the rounds."""
    keys = [(r["threads"], r["sampler"], r["steps"]) for r in runs[0]["rows"]]
    rows = []
    for i, (threads, sampler, steps) in enumerate(keys):
        chunk = statistics.median(run["rows"][i]["chunk_ms"] for run in runs)
        unet = statistics.median(run["rows"][i]["unet_ms"] for run in runs)
        rows.append({"threads": threads, "sampler": sampler, "steps": steps, "chunk_ms": chunk, "unet_ms": unet,
                     "loop_ms_per_step": (chunk - steps * unet) / steps})
    return rows


def markdown(result: dict) -> str:
    lines = ["# scdp's denoising loop beside LeRobot's (same U-Net shape, batch 1, one machine)", "",
             f"`{result['command']}` ({result['minutes']:.1f} min; {result['gflops']:.0f} GFLOP/s fp32 matmul, 2 cores; "
             f"{result['rounds']} alternating rounds, medians). LeRobot {result['lerobot_version']} (torch "
             f"{result['lerobot']['torch']}, U-Net {result['lerobot']['parameters']:,} parameters) against scdp "
             f"(torch {result['scdp']['torch']}, U-Net {result['scdp']['parameters']:,}). Chunk: one cold chunk for "
             "one scene; U-Net: one call; loop per step: (chunk − steps × U-Net) / steps, the sampler's and the "
             "policy's own cost around the network.", "",
             "| threads | sampler | LeRobot chunk ms | scdp chunk ms | scdp / LeRobot | LeRobot U-Net ms | scdp U-Net ms | "
             "LeRobot loop ms/step | scdp loop ms/step |", "|---|---|---|---|---|---|---|---|---|"]
    for lr, sc in zip(result["lerobot"]["rows"], result["scdp"]["rows"]):
        lines.append(f"| {lr['threads']} | {lr['sampler'].upper()}-{lr['steps']} | {lr['chunk_ms']:.1f} | {sc['chunk_ms']:.1f} | "
                     f"{sc['chunk_ms'] / lr['chunk_ms']:.2f} | {lr['unet_ms']:.2f} | {sc['unet_ms']:.2f} | "
                     f"{lr['loop_ms_per_step']:.2f} | {sc['loop_ms_per_step']:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("side", nargs="?", choices=["lerobot"], help="lerobot: time LeRobot's side only (in its venv), print JSON")
    p.add_argument("--checkpoints", type=Path, default=Path("results/cpu/navigation/checkpoints"))
    p.add_argument("--rounds", type=int, default=3, help="alternating rounds of both sides (default 3)")
    p.add_argument("--out", type=Path, default=Path("results/benchmarks/lerobot_speed"))
    args = p.parse_args(argv)
    if args.side == "lerobot":
        print(json.dumps(lerobot_side()))
        return 0
    from realtime import matmul_gflops  # a sibling benchmark, in scdp's environment

    from scdp.io import write_report

    python = os.environ.get("LEROBOT_PYTHON")
    if not python:
        raise SystemExit("set LEROBOT_PYTHON to the python of a venv with lerobot (benchmarks/lerobot_check.py has the recipe)")
    started, gflops, runs = time.perf_counter(), matmul_gflops(), {"scdp": [], "lerobot": []}
    env = {**USER_ENV, "HF_HUB_OFFLINE": "1"}  # LeRobot as its users run it, without scdp's thread settings
    for _ in range(args.rounds):
        runs["scdp"].append(scdp_side(args.checkpoints))
        done = subprocess.run([python, __file__, "lerobot"], capture_output=True, text=True, check=True, env=env,
                              cwd=Path(__file__).parent)
        runs["lerobot"].append(json.loads(done.stdout.strip().splitlines()[-1]))
    version = subprocess.run([python, "-c", "import importlib.metadata as m; print(m.version('lerobot'))"],
                             capture_output=True, text=True, check=True).stdout.strip()
    result = {"command": "python benchmarks/lerobot_speed.py " + " ".join(argv if argv is not None else sys.argv[1:]),
              "gflops": gflops, "rounds": args.rounds, "lerobot_version": version,
              "scdp": {**{k: v for k, v in runs["scdp"][0].items() if k != "rows"}, "rows": median_rows(runs["scdp"])},
              "lerobot": {**{k: v for k, v in runs["lerobot"][0].items() if k != "rows"}, "rows": median_rows(runs["lerobot"])}}
    result["minutes"] = (time.perf_counter() - started) / 60
    text = markdown(result)
    write_report(args.out.with_suffix(".md"), text, result)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
