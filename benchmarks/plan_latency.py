"""Planning latency and throughput on this machine, against its hardware floor.

Regenerates: `results/benchmarks/plan_latency*.md`

    python benchmarks/plan_latency.py --checkpoints runs/cpu/navigation/checkpoints [--task navigation] \
        [--out results/benchmarks/plan_latency]

Measures, in one run (run it alone: it times things):

* the hardware: fp32 matmul peak (FLOP/s) and memory bandwidth (bytes/s of a large copy), each
  the best of 20 calls;
* per preset (``cpu`` from the trained checkpoints, ``paper`` with untrained weights of its
  size) and per planner (dp, scdp, ld): one chunk at batch 1 with the preset's sampler, with
  DDPM at 20 steps (the fewest that keep T and success, ``results/benchmarks/sampler_sweep_*.md``)
  and with DDIM at 10; one denoising network call at batch 1, with the stride-1 convolutions
  as GEMMs (the default at batch 1, :class:`scdp.models.gemm_conv.Conv1d`) and as oneDNN
  convolutions ("conv as GEMM");
* the floor of one denoising call at batch 1: max(FLOPs / matmul peak, weight bytes / bandwidth),
  and the measured call's ratio to it;
* with the cpu checkpoints: planning seconds of a whole SCDP trajectory at batch 1 (median
  over scenes), and batched throughput in trajectories per minute (``--batch`` scenes at once);
* start-up: wall time of ``scdp --help`` and of importing what ``scdp plan`` needs.

Batch-1 measurements use the pool ``scdp plan`` and ``scdp serve`` use
(:func:`scdp.threads.use_for_planning`: one thread for the cpu preset's small network, every
core for the paper's, unless chosen); the hardware and the batched run use torch's full pool.
Both are recorded.

Writes ``OUT.json`` (with ``cpu_scdp_trajectory_s``, ``paper_scdp_chunk_s``,
``batched_trajectories_per_min`` and ``floor_ratio_batch1`` at the top level) and ``OUT.md``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch
from safetensors.torch import save_file
from torch.utils.flop_counter import FlopCounterMode

import scdp  # noqa: F401  - first, so that torch loads under scdp's thread policy (scdp.threads), as in real use
from scdp import threads
from scdp.config import GuidanceConfig
from scdp.data.scenes import BENCHMARK, sample_scenes
from scdp.evaluation.rollout import rollout
from scdp.io import write_json, write_text
from scdp.models import gemm_conv
from scdp.policies.base import observe_histories
from scdp.policies.exported import OnnxDenoiser, export_denoiser
from scdp.policies.legibility_diffuser import LegibilityDiffuser
from scdp.policies.loaders import load_method
from scdp.policies.scdp import StyleConditionedPolicy
from scdp.presets import get_preset
from scdp.tasks import get_task
from scdp.training.parts import build_diffusion, build_encoder, build_style


def call_seconds(fn, repeats: int, warmup: int = 1) -> list[float]:
    """Wall seconds of ``repeats`` calls of ``fn`` after ``warmup`` untimed ones."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return times


def median_seconds(fn, repeats: int, warmup: int = 1) -> float:
    return statistics.median(call_seconds(fn, repeats, warmup))


def best_seconds(fn, repeats: int, warmup: int = 1) -> float:
    """The fastest call: a peak, as a roofline needs (the median of a shared machine's memory
    copies moved by 1.6x between runs)."""
    return min(call_seconds(fn, repeats, warmup))


def hardware() -> dict:
    """Peak fp32 matmul FLOP/s and memory bandwidth (bytes read + written by a 256 MB copy), best of 20."""
    a, b = torch.randn(2048, 2048), torch.randn(2048, 2048)
    mm = best_seconds(lambda: torch.mm(a, b), 20, warmup=3)
    src, dst = torch.randn(64 * 2**20), torch.empty(64 * 2**20)  # 256 MB each
    copy = best_seconds(lambda: dst.copy_(src), 20, warmup=2)
    return {"matmul_flops_per_s": 2 * 2048**3 / mm, "bandwidth_bytes_per_s": 2 * src.numel() * 4 / copy,
            "threads": torch.get_num_threads()}


def untrained_planners(task, preset) -> dict:
    """dp, scdp (auto) and ld of a preset's size, with freshly initialised weights."""
    base = build_diffusion(task, preset).eval()
    encoder = build_encoder(task, preset).eval()
    predictors = {s: build_style(preset, base, encoder).eval() for s in ("legible", "efficient")}
    return {"dp": base, "scdp": StyleConditionedPolicy(base, encoder, predictors, task, "auto"),
            "ld": LegibilityDiffuser(build_diffusion(task, preset, ld=True).eval(), GuidanceConfig())}


def bases(planner) -> list:
    """The DiffusionPolicy objects a planner samples from."""
    found = [getattr(planner, "base", None), getattr(planner, "policy", None)]
    return [p for p in found if p is not None] or [planner]


def with_sampler(planner, sampler: str, steps: int):
    """The same planner, its base switched to ``sampler`` at ``steps`` steps."""
    for policy in bases(planner):
        policy.use_sampler(sampler, steps)
    return planner


def to_onnx(planners: dict, workdir: Path) -> dict:
    """The same planners with every denoiser exported (parity-checked) and run by ONNX Runtime on
    torch's current thread count (:mod:`scdp.policies.exported`)."""
    done: dict = {}
    for planner in planners.values():
        for policy in bases(planner):
            if id(policy) in done:
                continue
            cfg, folder = policy.config, workdir / f"net{len(done)}"
            folder.mkdir(parents=True, exist_ok=True)  # the weights beside the graph, which is bound to them
            save_file({k: v.contiguous() for k, v in policy.unet.state_dict().items()}, str(folder / "model.safetensors"))
            export_denoiser(policy.unet, folder, horizon=cfg.horizon, state_dim=cfg.state_dim, cond_dim=cfg.global_cond_dim,
                            steps=cfg.num_train_timesteps)
            policy.unet = OnnxDenoiser(folder)
            done[id(policy)] = folder
    return planners


def onnx_call_seconds(policy) -> float:
    cfg = policy.config
    x, k, cond = torch.randn(1, cfg.horizon, cfg.state_dim), torch.tensor([10]), torch.randn(1, cfg.global_cond_dim)
    return median_seconds(lambda: policy.unet(x, k, cond), 20, warmup=3)


def network_call(policy) -> dict:
    """One denoising call of the U-Net at batch 1: FLOPs, weight bytes, median seconds."""
    cfg = policy.config
    x, k = torch.randn(1, cfg.horizon, cfg.state_dim), torch.tensor([10])
    cond = torch.randn(1, cfg.global_cond_dim)
    with torch.inference_mode():
        with FlopCounterMode(display=False) as counter:
            policy.unet(x, k, cond)
        seconds = median_seconds(lambda: policy.unet(x, k, cond), 20, warmup=3)
        gemm_positions, gemm_conv.GEMM_POSITIONS = gemm_conv.GEMM_POSITIONS, 0  # every convolution through oneDNN
        try:
            conv_seconds = median_seconds(lambda: policy.unet(x, k, cond), 20, warmup=3)
        finally:
            gemm_conv.GEMM_POSITIONS = gemm_positions
    weights = sum(p.numel() * p.element_size() for p in policy.unet.parameters())
    return {"flops": counter.get_total_flops(), "weight_bytes": weights, "seconds": seconds, "conv_seconds": conv_seconds}


def chunk_seconds(task, planner, repeats: int) -> float:
    goals, target = sample_scenes(task, 1, seed=5, stream=BENCHMARK)[0]
    obs = observe_histories(task, [task.nominal_start()[None]], [goals], [target], planner.n_obs_steps)

    def act():
        planner.reset()
        with torch.inference_mode():
            planner.act(obs, [torch.Generator().manual_seed(0)])
    return median_seconds(act, repeats)


def start_up() -> dict:
    def run(args):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, *args], check=True, capture_output=True)
        return time.perf_counter() - t0
    return {"scdp_help_s": min(run(["-m", "scdp", "--help"]) for _ in range(3)),
            "import_plan_s": min(run(["-c", "import scdp.cli.plan"]) for _ in range(3))}


FAST_SAMPLERS = (("ddpm", 20), ("ddim", 10))


def preset_rows(task, name: str, planners: dict, hw: dict, repeats: int, onnx_dir: Path | None = None,
                torch_row: dict | None = None) -> dict:
    """One preset's row; with ``onnx_dir``, its planners' denoisers are exported there first and run by
    ONNX Runtime (``torch_row`` gives the network's FLOPs and weight bytes: the floor is the same)."""
    base = planners["dp"]
    parameters = torch_row["parameters"] if torch_row else sum(p.numel() for p in base.unet.parameters())
    batch1_threads = threads.use_for_planning(parameters)
    if onnx_dir is not None:
        planners = to_onnx(planners, onnx_dir)  # sessions on the batch-1 pool just set
        call = {"flops": torch_row["network_flops"], "weight_bytes": torch_row["weight_bytes"],
                "seconds": onnx_call_seconds(base), "conv_seconds": float("nan")}
    else:
        call = network_call(base)
    floor = max(call["flops"] / hw["matmul_flops_per_s"], call["weight_bytes"] / hw["bandwidth_bytes_per_s"])
    row = {"parameters": parameters, "batch1_threads": batch1_threads, "sampler": base.config.sampler,
           "steps": base.config.num_inference_steps, "network_call_s": call["seconds"],
           "network_call_conv_s": call["conv_seconds"], "network_flops": call["flops"],
           "weight_bytes": call["weight_bytes"], "floor_s": floor, "floor_ratio": call["seconds"] / floor,
           "bound": "memory" if call["weight_bytes"] / hw["bandwidth_bytes_per_s"] > call["flops"] / hw["matmul_flops_per_s"]
           else "compute", "chunk_s": {}}
    sampler, steps = base.config.sampler, base.config.num_inference_steps
    for method, planner in planners.items():
        row["chunk_s"][method] = {f"{sampler}-{steps}": chunk_seconds(task, planner, repeats)}
        for fast, k in FAST_SAMPLERS:
            row["chunk_s"][method][f"{fast}-{k}"] = chunk_seconds(task, with_sampler(planner, fast, k), repeats)
        with_sampler(planner, sampler, steps)
    net = steps * call["seconds"]
    row["scdp_overhead_s"] = row["chunk_s"]["scdp"][f"{sampler}-{steps}"] - net
    row["runtime"] = "torch" if onnx_dir is None else "onnx"
    print(f"[{name}, {row['runtime']}] {row['parameters'] / 1e6:.2f} M parameters, call {1000 * call['seconds']:.2f} ms "
          f"(floor {1000 * floor:.2f} ms, x{row['floor_ratio']:.1f}), chunks {row['chunk_s']}", flush=True)
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoints", type=Path, default=Path("runs/cpu/navigation/checkpoints"))
    parser.add_argument("--task", default="navigation")
    parser.add_argument("--repeats", type=int, default=5, help="timed repeats per chunk measurement (median)")
    parser.add_argument("--trajectories", type=int, default=5, help="batch-1 trajectories timed (median)")
    parser.add_argument("--batch", type=int, default=256, help="scenes in the batched throughput run")
    parser.add_argument("--out", type=Path, default=Path("results/benchmarks/plan_latency"))
    args = parser.parse_args()
    task = get_task(args.task)
    t_start = time.perf_counter()
    hw = hardware()
    print(f"matmul {hw['matmul_flops_per_s'] / 1e9:.1f} GFLOP/s, copy {hw['bandwidth_bytes_per_s'] / 1e9:.1f} GB/s, "
          f"{hw['threads']} threads", flush=True)
    pool = torch.get_num_threads()
    cpu = {m: load_method(m, args.checkpoints, task) for m in ("dp", "scdp", "ld")}
    work = Path(tempfile.mkdtemp(prefix="scdp-onnx-"))
    paper_repeats = max(1, args.repeats // 2)
    rows = {"paper": preset_rows(task, "paper", untrained_planners(task, get_preset("paper")), hw, paper_repeats)}
    rows["paper_onnx"] = preset_rows(task, "paper", untrained_planners(task, get_preset("paper")), hw, paper_repeats,
                                     work / "paper", rows["paper"])
    rows["cpu"] = preset_rows(task, "cpu", cpu, hw, args.repeats)
    cpu_onnx = {m: load_method(m, args.checkpoints, task) for m in ("dp", "scdp", "ld")}
    rows["cpu_onnx"] = preset_rows(task, "cpu", cpu_onnx, hw, args.repeats, work / "cpu", rows["cpu"])
    planning_threads = rows["cpu"]["batch1_threads"]  # cpu last: its pool is the one batch 1 runs below

    scenes = sample_scenes(task, max(args.batch, args.trajectories), seed=21, stream=BENCHMARK)
    single = [rollout(task, cpu["scdp"], [scene], seed=i)[0] for i, scene in enumerate(scenes[:args.trajectories])]
    single_onnx = [rollout(task, cpu_onnx["scdp"], [scene], seed=i)[0] for i, scene in enumerate(scenes[:args.trajectories])]
    torch.set_num_threads(pool)
    t0 = time.perf_counter()
    batched = rollout(task, cpu["scdp"], scenes[:args.batch], seed=0)
    batch_wall = time.perf_counter() - t0
    planning = sum(r.seconds for r in batched)
    paper = rows["paper"]
    result = {
        "cpu_scdp_trajectory_s": statistics.median(r.seconds for r in single),
        "cpu_scdp_trajectory_s_onnx": statistics.median(r.seconds for r in single_onnx),
        "paper_scdp_chunk_s_ddpm20_onnx": rows["paper_onnx"]["chunk_s"]["scdp"]["ddpm-20"],
        "floor_ratio_batch1_onnx": rows["paper_onnx"]["floor_ratio"],
        "paper_scdp_chunk_s": paper["chunk_s"]["scdp"][f"{paper['sampler']}-{paper['steps']}"],
        "paper_scdp_chunk_s_ddpm20": paper["chunk_s"]["scdp"]["ddpm-20"],
        "paper_scdp_chunk_s_ddim10": paper["chunk_s"]["scdp"]["ddim-10"],
        "paper_batch1_threads": paper["batch1_threads"],
        "batched_trajectories_per_min": 60 * args.batch / planning,
        "batched_trajectories_per_min_with_simulation": 60 * args.batch / batch_wall,
        "floor_ratio_batch1": paper["floor_ratio"],
        "cpu_chunks_per_trajectory": statistics.median(len(r.styles) for r in single),
        "batch1_threads": planning_threads, "batched_threads": pool, "hardware": hw, "presets": rows, "start_up": start_up(),
        "task": task.name, "checkpoints": str(args.checkpoints),
        "cpu_count": os.cpu_count(), "compute_minutes": round((time.perf_counter() - t_start) / 60, 2),
        "command": " ".join(["python", "benchmarks/plan_latency.py", *sys.argv[1:]]),
    }
    write_json(args.out.with_suffix(".json"), result)
    write_text(args.out.with_suffix(".md"), markdown(result))
    print(markdown(result))


def markdown(r: dict) -> str:
    lines = ["# Planning latency and throughput", "", f"`{r['command']}` ({r['cpu_count']} CPU cores; torch threads at "
             f"batch 1: {r['batch1_threads']} for the cpu preset, {r['paper_batch1_threads']} for the paper preset; "
             f"{r['batched_threads']} batched; {r['compute_minutes']} min)", "",
             f"Hardware, measured in the same run: fp32 matmul {r['hardware']['matmul_flops_per_s'] / 1e9:.1f} GFLOP/s, "
             f"copy bandwidth {r['hardware']['bandwidth_bytes_per_s'] / 1e9:.1f} GB/s.", "",
             "| measure | value |", "|---|---|",
             f"| cpu preset: SCDP trajectory planning at batch 1 (median) | {r['cpu_scdp_trajectory_s']:.3f} s "
             f"({r['cpu_chunks_per_trajectory']} chunks) |",
             f"| ... with --runtime onnx | {r['cpu_scdp_trajectory_s_onnx']:.3f} s |",
             f"| paper preset: SCDP chunk at batch 1, own sampler | {r['paper_scdp_chunk_s']:.3f} s |",
             f"| paper preset: SCDP chunk at batch 1, DDPM-20 | {r['paper_scdp_chunk_s_ddpm20']:.3f} s |",
             f"| ... with --runtime onnx | {r['paper_scdp_chunk_s_ddpm20_onnx']:.3f} s |",
             f"| paper preset: SCDP chunk at batch 1, DDIM-10 | {r['paper_scdp_chunk_s_ddim10']:.3f} s |",
             f"| cpu preset: batched SCDP trajectories per minute (planning time) | {r['batched_trajectories_per_min']:.0f} |",
             f"| ... including simulation | {r['batched_trajectories_per_min_with_simulation']:.0f} |",
             f"| paper preset: network call / hardware floor at batch 1 | {r['floor_ratio_batch1']:.2f} |",
             f"| ... with --runtime onnx | {r['floor_ratio_batch1_onnx']:.2f} |",
             f"| start-up: `scdp --help` / `import scdp.cli.plan` | {r['start_up']['scdp_help_s']:.2f} s / "
             f"{r['start_up']['import_plan_s']:.2f} s |", "",
             "| preset | runtime | parameters | threads | sampler | network call ms | ... conv as oneDNN ms | floor ms | bound | ratio | "
             "dp chunk s | scdp chunk s | ld chunk s | dp / scdp / ld chunk s at DDPM-20 | at DDIM-10 | "
             "SCDP non-network s per chunk |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for key, p in r["presets"].items():
        name = key.removesuffix("_onnx")
        own = f"{p['sampler']}-{p['steps']}"
        c = p["chunk_s"]
        fast = [" / ".join(f"{c[m][f'{s}-{k}']:.3f}" for m in ("dp", "scdp", "ld")) for s, k in FAST_SAMPLERS]
        lines.append(f"| {name} | {p.get('runtime', 'torch')} | {p['parameters'] / 1e6:.2f} M | {p['batch1_threads']} | {own} | "
                     f"{1000 * p['network_call_s']:.2f} | {1000 * p['network_call_conv_s']:.2f} | "
                     f"{1000 * p['floor_s']:.3f} | {p['bound']} | {p['floor_ratio']:.1f} | {c['dp'][own]:.3f} | "
                     f"{c['scdp'][own]:.3f} | {c['ld'][own]:.3f} | {fast[0]} | {fast[1]} | {p['scdp_overhead_s']:.3f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
