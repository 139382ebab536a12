"""How long a preset's reproduction takes on this machine's device, estimated before running it
(issue 67: size the paper preset's GPU run to the GPU time at hand, with room for one retry).

Regenerates: `results/benchmarks/paper_sizing_tiny_cpu.md`

    python benchmarks/paper_sizing.py --task navigation --preset paper --device cuda --out results/benchmarks/paper_sizing_h200
    python benchmarks/paper_sizing.py --preset tiny --device cpu --out results/benchmarks/paper_sizing_tiny_cpu   # the logic, on a CPU

Each estimate is one short timed measurement scaled by the preset's own counts:

1. **demos**: ``--probe-demos`` demonstrations generated and timed; seconds per demo x ``data.num_demos``,
   and the windows per demo that set the training steps.
2. **base** and **ld**: the network built at the preset's size on the device, ``--steps`` optimiser
   steps at the schedule's batch size timed after two warm-up steps; x epochs x ceil(windows / batch).
3. **evaluate**: one SCDP planning call for a batch of scenes, from fresh parts of the preset's size
   at its sampler; x (an upper bound of) chunks per trajectory x batches of the evaluated trajectories.

The scene encoder and the style predictors (about 1 M parameters each at the paper's size) are not
timed here. Writes ``OUT.json`` and ``OUT.md``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import torch

from scdp.data.generate import generate_demos
from scdp.data.windows import WindowData
from scdp.devices import describe, resolve
from scdp.io import write_json, write_text
from scdp.policies.base import act, observe_histories
from scdp.policies.scdp import StyleConditionedPolicy
from scdp.presets import get_preset
from scdp.tasks import get_task
from scdp.training import parts

WARMUP = 2


def sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize()


def demos_estimate(task, preset, probe: int) -> tuple[dict, object]:
    t0 = time.perf_counter()
    dataset, _ = generate_demos(task, probe, preset.data.seed, progress=False)
    per_demo = (time.perf_counter() - t0) / probe
    model = preset.base.model
    windows = len(WindowData(dataset, model.n_obs_steps, model.horizon, task)) / probe
    return {"seconds_per_demo": per_demo, "windows_per_demo": windows,
            "minutes": per_demo * preset.data.num_demos / 60}, dataset


def training_estimate(task, preset, dataset, part: str, device: torch.device, steps: int, windows: float) -> dict:
    """Seconds per optimiser step of ``part`` (base or ld) at its schedule's batch, and the stage's minutes."""
    schedule = preset.schedule(part)
    model = preset.base.model
    data = WindowData(dataset, model.n_obs_steps, model.horizon, task)
    policy = parts.build_diffusion(task, preset, data, ld=part == "ld").to(device)
    optimizer = torch.optim.AdamW(policy.parameters(), lr=schedule.lr)
    generator = torch.Generator().manual_seed(0)
    rows = np.arange(schedule.batch_size) % len(data)
    batch = data.get(torch.as_tensor(rows)).to(device)
    timed = []
    for i in range(WARMUP + steps):
        sync(device)
        t0 = time.perf_counter()
        loss = policy.loss(batch, generator=generator)
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        sync(device)
        if i >= WARMUP:
            timed.append(time.perf_counter() - t0)
    per_step = float(np.median(timed))
    total = schedule.epochs * math.ceil(windows * (preset.data.base_demos or preset.data.num_demos) / schedule.batch_size)
    return {"seconds_per_step": per_step, "steps": total, "minutes": per_step * total / 60,
            "batch_size": schedule.batch_size, "parameters": sum(p.numel() for p in policy.parameters())}


def evaluation_estimate(task, preset, device: torch.device, reps: int) -> dict:
    """Seconds of one SCDP planning call for a batch of scenes at the preset's sampler, and the stage's minutes."""
    base = parts.build_diffusion(task, preset).to(device).eval()
    encoder = parts.build_encoder(task, preset).to(device).eval()
    styles = {s: parts.build_style(preset, base, encoder, f"style_{s}").to(device).eval() for s in ("legible", "efficient")}
    planner = StyleConditionedPolicy(base, encoder, styles, task, arbitration=preset.style.arbitration)
    ev = preset.evaluation
    batch = min(2 * ev.scenes, 256)
    rng = np.random.default_rng(0)
    goals = [task.sample_goals(rng, 2) for _ in range(batch)]
    start = task.nominal_start()
    obs = observe_histories(task, [[start]] * batch, goals, [0] * batch, planner.n_obs_steps)
    timed = []
    for i in range(1 + reps):
        gens = [torch.Generator().manual_seed(k) for k in range(batch)]
        sync(device)
        t0 = time.perf_counter()
        act(planner, obs, gens)
        sync(device)
        if i:
            timed.append(time.perf_counter() - t0)
    per_call = float(np.median(timed))
    chunks = math.ceil(task.max_episode_steps / planner.n_action_steps)  # an upper bound: most scenes end sooner
    trajectories = len(ev.methods) * (2 * ev.scenes + 12 * ev.layout_repeats)
    return {"seconds_per_call": per_call, "batch": batch, "chunks_per_trajectory_at_most": chunks,
            "trajectories": trajectories, "minutes_at_most": per_call * chunks * math.ceil(trajectories / batch) / 60,
            "sampler": [base.config.sampler, base.config.num_inference_steps]}


def report(r: dict, command: str) -> str:
    rows = [("demos", r["demos"]["minutes"], f"{r['demos']['seconds_per_demo']:.3f} s per demo x {r['num_demos']}"),
            *((part, r[part]["minutes"], f"{r[part]['seconds_per_step'] * 1000:.1f} ms per step x {r[part]['steps']} steps "
               f"(batch {r[part]['batch_size']}, {r[part]['parameters'] / 1e6:.1f} M parameters)") for part in ("base", "ld")),
            ("evaluate (at most)", r["evaluate"]["minutes_at_most"],
             f"{r['evaluate']['seconds_per_call']:.3f} s per call of {r['evaluate']['batch']} scenes x "
             f"{r['evaluate']['chunks_per_trajectory_at_most']} chunks x "
             f"{math.ceil(r['evaluate']['trajectories'] / r['evaluate']['batch'])} batches")]
    total = sum(m for _, m, _ in rows)
    lines = [f"# Sizing the {r['preset']} preset's reproduction on {r['device']}", "",
             f"`{command}` ({r['task']}; {r['minutes']:.1f} min to measure). Estimates, each from one short timed "
             "measurement scaled by the preset's counts; the encoder and the style predictors are not timed.", "",
             "| stage | minutes (estimate) | from |", "|---|---|---|",
             *(f"| {name} | {m:.1f} | {how} |" for name, m, how in rows),
             f"| **the timed stages** | **{total:.1f}** | with one retry: {2 * total:.1f} |"]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--task", default="navigation")
    p.add_argument("--preset", default="paper")
    p.add_argument("--device", default="auto", help="cpu, cuda or auto")
    p.add_argument("--probe-demos", type=int, default=20, help="demonstrations generated to time and size the demos")
    p.add_argument("--steps", type=int, default=5, help="timed optimiser steps per network")
    p.add_argument("--reps", type=int, default=3, help="timed planning calls")
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args(argv)
    command = " ".join(["python", "benchmarks/paper_sizing.py", *(argv if argv is not None else sys.argv[1:])])
    task, preset, device = get_task(args.task), get_preset(args.preset), resolve(args.device)
    t0 = time.perf_counter()
    demos, dataset = demos_estimate(task, preset, args.probe_demos)
    result = {"task": task.name, "preset": preset.name, "device": describe(device), "num_demos": preset.data.num_demos,
              "demos": demos}
    for part in ("base", "ld"):
        result[part] = training_estimate(task, preset, dataset, part, device, args.steps, demos["windows_per_demo"])
    result["evaluate"] = evaluation_estimate(task, preset, device, args.reps)
    result["minutes"] = (time.perf_counter() - t0) / 60
    write_json(args.out.with_suffix(".json"), result)
    write_text(args.out.with_suffix(".md"), report(result, command))
    print(report(result, command))
    return 0


if __name__ == "__main__":
    sys.exit(main())
