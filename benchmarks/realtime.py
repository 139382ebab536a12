"""Real-time planning with the style kept: a fast planner against today's default, quality then latency.

Regenerates: `results/benchmarks/realtime.md`, `results/benchmarks/realtime_null.md`

    python benchmarks/realtime.py --run results/cpu --steps 8 --warm-skip 4 [--scenes 100] \
        [--out results/benchmarks/realtime]

**Quality gate.** For each task, every method of ``--methods`` plans the same ``--scenes`` ambiguous
+ ``--scenes`` clear validation scenes (the validation stream, never the evaluation's) with the
same per-scene noise, twice: with the checkpoints' own sampler, cold (the default), and with the
fast planner (DDPM respaced to ``--steps``, warm-started at ``--warm-skip``). Per method and scene
set: success, and the paired differences fast - default of T, D̂ and Ê with 95 % scene-bootstrap
intervals; the forced-style D̂ gap (``scdp_legible`` - ``scdp_efficient``) of each planner; the
share of warm-started chunks and the cold-start reasons. The gate (issue 39) passes when, for every
method and set, success >= 0.98 and each of ΔT, ΔD̂, ΔÊ has its whole interval inside ±0.02, and
the fast forced-style gap is >= 95 % of the default's in each set.

**Latency at batch 1** (one scene, one thread as ``scdp plan`` uses), default and fast side by side
in one run, with the machine's measured fp32 matmul rate: a cpu-preset SCDP trajectory (median
over ``--latency-scenes`` scenes) and its chunk; the ratio default / fast is what carries to
another machine. ``--paper-trajectories N`` adds the paper's network size (freshly initialised
weights: the time does not depend on them): N trajectories of ``PAPER_CHUNKS`` chunks each, the
robot taking every planned action (the warm-start rules of the control-loop policy), with the threads ``scdp plan``
gives a network that size. Run it alone on the machine.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
from plan_latency import bases, to_onnx, untrained_planners  # a sibling benchmark

from scdp import threads
from scdp.config import PlanningOptions
from scdp.data.scenes import VALIDATION, scene_seed
from scdp.evaluation.protocol import scene_sets
from scdp.evaluation.records import scene_bounds, score_rollout
from scdp.evaluation.rollout import rollout
from scdp.evaluation.statistics import compare
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.metrics import MIN_SUCCESS
from scdp.policies.base import Observation, WarmStart, act
from scdp.policies.loaders import load_diffusion, load_method
from scdp.presets import get_preset
from scdp.tasks import get_task

METRICS = (("transparency", "T"), ("d_hat", "D̂"), ("e_hat", "Ê"))
TOLERANCE, GAP_SHARE = 0.02, 0.95  # with scdp.metrics.MIN_SUCCESS


def matmul_gflops(n: int = 1024, repeats: int = 10) -> float:
    """This machine's fp32 matmul rate (GFLOP/s) on the threads torch uses now."""
    a, b = torch.randn(n, n), torch.randn(n, n)
    a @ b  # warm-up
    t0 = time.perf_counter()
    for _ in range(repeats):
        a @ b
    return 2 * n ** 3 * repeats / (time.perf_counter() - t0) / 1e9


def run_method(task, checkpoints, method, planning, sets, seed, noise: str = ""):
    """Records and chunk starts of one method under one planner, all scenes batched. ``noise`` names
    another noise stream for the same scenes ("": the evaluation's)."""
    planner = load_method(method, checkpoints, task, planning)
    labelled = [(name, i, scene) for name, scenes in sets.items() for i, scene in enumerate(scenes)]
    runs = rollout(task, planner, [s for *_, s in labelled], seeds=[scene_seed(seed, n + noise, i) for n, i, _ in labelled])
    cache = {}
    records = [score_rollout(task, r, method=method, scene_set=n, scene_index=i, bounds=scene_bounds(task, r.goals, r.target, cache))
               for (n, i, _), r in zip(labelled, runs)]
    return records, Counter(s for r in runs for s in r.starts)


def gate(task, checkpoints, methods, fast, scenes, seed, noise: str = "") -> dict:
    """The gate of the module docstring; with ``noise`` (the null check), ``fast`` plans the same
    scenes with the noise of that stream instead of the default's."""
    sets = {k: v for k, v in scene_sets(task, scenes, seed, stream=VALIDATION).items() if k in (AMBIGUOUS, CLEAR)}
    rows, gaps = [], {}
    for method in methods:
        default, _ = run_method(task, checkpoints, method, PlanningOptions(), sets, seed)
        quick, starts = run_method(task, checkpoints, method, fast, sets, seed, noise)
        both = [replace(r, method="fast") for r in quick] + default
        row = {"method": method, "starts": dict(starts), "warm_share": starts["warm"] / max(1, sum(starts.values()))}
        for scene_set in (AMBIGUOUS, CLEAR):
            subset = [r for r in both if r.scene_set == scene_set]
            row[scene_set] = {"success_default": float(np.mean([r.success for r in default if r.scene_set == scene_set])),
                              "success_fast": float(np.mean([r.success for r in quick if r.scene_set == scene_set]))}
            for metric, _ in METRICS:
                c = compare(subset, "fast", method, metric)
                row[scene_set][metric] = {"mean": c.mean, "lo": c.lo, "hi": c.hi}
            for name, records in (("default", default), ("fast", quick)):
                gaps.setdefault((method, scene_set, name), float(np.mean(
                    [r.metrics["d_hat"] for r in records if r.scene_set == scene_set])))
        rows.append(row)
        print(task.name, method, {k: row[k] for k in ("starts", "warm_share")}, flush=True)
    out = {"rows": rows, "forced_gap": {}}
    if {"scdp_legible", "scdp_efficient"} <= set(methods):
        for scene_set in (AMBIGUOUS, CLEAR):
            g = {p: gaps["scdp_legible", scene_set, p] - gaps["scdp_efficient", scene_set, p] for p in ("default", "fast")}
            out["forced_gap"][scene_set] = {**g, "share": g["fast"] / g["default"] if g["default"] else float("nan")}
    cells = [(r[s]["success_fast"], r[s][m]) for r in rows for s in (AMBIGUOUS, CLEAR) for m, _ in METRICS]
    out["passes"] = bool(all(ok >= MIN_SUCCESS and -TOLERANCE <= c["lo"] and c["hi"] <= TOLERANCE for ok, c in cells)
                         and all(v["share"] >= GAP_SHARE for v in out["forced_gap"].values()))
    return out


def latency(task, checkpoints, fast, scenes: int, seed: int, runtimes=("torch",)) -> dict:
    """Batch-1 SCDP trajectory and chunk seconds, default and fast under each runtime, interleaved
    scene by scene; keys ``default`` and ``fast`` are torch's, ``default/onnx`` and ``fast/onnx`` ONNX Runtime's."""
    threads.use_for_planning(1)
    planners = {}
    for runtime in runtimes:
        tail = "" if runtime == "torch" else f"/{runtime}"
        planners[f"default{tail}"] = load_method("scdp", checkpoints, task, PlanningOptions(runtime=runtime))
        planners[f"fast{tail}"] = load_method("scdp", checkpoints, task, replace(fast, runtime=runtime))
    sets = scene_sets(task, scenes, seed, stream=VALIDATION)
    picks = (sets[AMBIGUOUS] + sets[CLEAR])[:scenes]
    seconds = {k: [] for k in planners}
    chunks = {k: [] for k in planners}
    for i, scene in enumerate(picks):
        for name, planner in planners.items():
            (run,) = rollout(task, planner, [scene], seeds=[scene_seed(seed, "latency", i)])
            seconds[name].append(run.seconds)
            chunks[name].append(run.seconds / max(1, len(run.styles)))
    med = {k: float(np.median(v)) for k, v in seconds.items()}
    return {"trajectory_s": med, "chunk_s": {k: float(np.median(v)) for k, v in chunks.items()},
            "speedup": med["default"] / med["fast"], "ratios": {k: med["default"] / v for k, v in med.items()},
            "scenes": len(picks)}


PAPER_CHUNKS = 10  # chunks in a paper-size trajectory (a cpu-preset trajectory plans about 10)


def paper_latency(task, fast, trajectories: int, seed: int, workdir: Path) -> dict:
    """Batch-1 SCDP of the paper's size, default (its own sampler, cold) and fast, torch and ONNX
    Runtime: per planner the median trajectory seconds over ``trajectories`` runs of PAPER_CHUNKS
    chunks, the median cold and warm chunk, and how the chunks began."""
    preset = get_preset("paper")
    made = {}
    for runtime in ("torch", "onnx"):
        for name in ("default", "fast"):
            planner = untrained_planners(task, preset)["scdp"]
            thread_count = threads.use_for_planning(sum(p.numel() for p in bases(planner)[0].parameters()))
            if name == "fast":
                for policy in bases(planner):
                    policy.use_sampler(fast.sampler, fast.steps).use_warm_start(fast.warm_skip)
            if runtime == "onnx":
                planner = to_onnx({"scdp": planner}, workdir / name)["scdp"]
            made[name if runtime == "torch" else f"{name}/onnx"] = planner
    (goals, target), = scene_sets(task, 1, seed, stream=VALIDATION)[AMBIGUOUS][:1]
    env = task.make_env()
    out = {}
    for name, planner in made.items():
        totals, chunks, starts = [], {"cold": [], "warm": []}, Counter()
        for r in range(trajectories):
            obs, _ = env.reset(seed=scene_seed(seed, "paper", r), options={"goals": goals, "target": int(target)})
            history = [torch.as_tensor(obs["state"], dtype=torch.float32)]
            generator, last, total = torch.Generator().manual_seed(scene_seed(seed, "paper", r)), None, 0.0
            for _ in range(PAPER_CHUNKS):
                # the robot reaches every planned state; untrained weights plan states outside the task's
                # bounds, so the observation is built here rather than checked (observe_histories)
                hist = torch.stack([history[max(len(history) - planner.n_obs_steps + k, 0)]
                                    for k in range(planner.n_obs_steps)])[None]
                seen = Observation(hist, torch.as_tensor(task.task_space(hist[:, -1].double().numpy()), dtype=torch.float32),
                                   torch.as_tensor(env.goals[None], dtype=torch.float32), torch.tensor([int(target)]))
                warm = WarmStart.cold_start(1) if last is None else WarmStart.from_chunk(last, planner.n_action_steps)
                t0 = time.perf_counter()
                with torch.inference_mode():
                    last = act(planner, seen, [generator], warm)
                seconds = time.perf_counter() - t0
                total += seconds
                began = (last.starts or ["off"])[0]  # warm, or why this chunk started cold
                starts[began] += 1
                chunks["warm" if began == "warm" else "cold"].append(seconds)
                history += list(last.actions[0].float())
            totals.append(total)
        out[name] = {"trajectory_s": float(np.median(totals)), "starts": dict(starts),
                     **{f"{k}_chunk_s": float(np.median(v)) if v else float("nan") for k, v in chunks.items()}}
    default = out["default"]["trajectory_s"]
    for row in out.values():
        row["ratio"] = default / row["trajectory_s"]
    return {"planners": out, "threads": thread_count, "trajectories": trajectories, "chunks": PAPER_CHUNKS,
            "sampler": f"{preset.base.model.sampler}-{preset.base.model.num_inference_steps}"}


BATCHES = (1, 2, 4, 8, 16, 64, 200)


def runtime_crossover(checkpoints, task, repeats: int = 30) -> dict:
    """Milliseconds per network call of the base, torch against ONNX Runtime, per batch size
    (interleaved, median of ``repeats``): where ``--runtime auto`` should switch."""
    nets = {r: load_diffusion(checkpoints / "base", task, planning=PlanningOptions(runtime=r)) for r in ("torch", "onnx")}
    cfg = nets["torch"].config
    out = {}
    for batch in BATCHES:
        x, k = torch.randn(batch, cfg.horizon, cfg.state_dim), torch.full((batch,), 10, dtype=torch.long)
        cond = torch.randn(batch, cfg.global_cond_dim)
        times = {r: [] for r in nets}
        with torch.inference_mode():
            for _ in range(repeats):
                for r, net in nets.items():
                    t0 = time.perf_counter()
                    net.unet(x, k, cond)
                    times[r].append(time.perf_counter() - t0)
        out[batch] = {r: 1000 * float(np.median(v[3:])) for r, v in times.items()}
    return out


def markdown(result: dict) -> str:
    f = result["fast"]
    null = result.get("null", False)
    title = ("The gate's null check: the default planner against itself, its noise drawn again" if null else
             f"Real-time planning: DDPM-{f['steps']} warm-started at step {f['warm_skip']} against the default")
    same = ("the same scenes; \"fast\" below is the default planner itself with every scene's noise (start state "
            "and sampler) drawn from another stream, so any Δ is the noise's alone" if null
            else "the same noise for both planners")
    lines = [f"# {title}", "",
             f"`{result['command']}` ({result['compute_minutes']:.1f} compute-min; matmul {result['gflops']:.0f} GFLOP/s "
             f"fp32 on this machine). " + (f"{result['scenes']} ambiguous + {result['scenes']} clear validation scenes per task, "
             f"{same}. Δ = fast - default, mean [95 % scene-bootstrap interval]." if result["scenes"]
             else "Latency only, the machine otherwise idle."), ""]
    if result["scenes"] == 0 and not any("latency" in b for b in result["tasks"].values()):
        lines[0] = "# Real-time planning at the paper's network size: the fast planner against the default"
    for task, block in result["tasks"].items():
        g = block.get("gate")
        if g is None:  # --scenes 0: latency only
            lines += [f"## {task}", "", "Quality gate not run here (`--scenes 0`); it is in realtime.md (the cpu preset's "
                      "checkpoints).", ""]
            lines += _latency_lines(block)
            continue
        lines += [f"## {task}: gate {'PASSES' if g['passes'] else 'FAILS'}", "",
                  "| method | set | success default | success fast | ΔT | ΔD̂ | ΔÊ | warm chunks |", "|" + "---|" * 8]
        for r in g["rows"]:
            for s in (AMBIGUOUS, CLEAR):
                cells = [f"{r[s][m]['mean']:+.3f} [{r[s][m]['lo']:+.3f}, {r[s][m]['hi']:+.3f}]" for m, _ in METRICS]
                lines.append(f"| {r['method']} | {s} | {r[s]['success_default']:.3f} | {r[s]['success_fast']:.3f} | "
                             + " | ".join(cells) + f" | {r['warm_share']:.2f} |")
        lines += ["", "Chunk starts (fast planner): " + "; ".join(f"{r['method']}: " + ", ".join(
            f"{k} {v}" for k, v in sorted(r["starts"].items())) for r in g["rows"]), ""]
        for s, v in g["forced_gap"].items():
            lines.append(f"Forced-style D̂ gap, {s}: default {v['default']:.3f}, fast {v['fast']:.3f} "
                         f"({100 * v['share']:.0f} % of the default's; the gate asks >= {100 * GAP_SHARE:.0f} %).")
        lines += [""] + _latency_lines(block)
    return "\n".join(lines)


def _latency_lines(block: dict) -> list[str]:
    lat = block.get("latency")
    if lat is None:
        lines = [] if block.get("paper") else ["Latency not measured in this run (`--latency-scenes 0`: the gate only).", ""]
    else:
        lines = [f"Batch-1 SCDP, one thread, median of {lat['scenes']} validation scenes (default = the checkpoints' own "
                 "sampler, cold; fast = the planner above):", "",
                 "| planner | trajectory s | chunk s | default torch / this |", "|---|---|---|---|"]
        for name, seconds in lat["trajectory_s"].items():
            lines.append(f"| {name} | {seconds:.3f} | {lat['chunk_s'][name]:.4f} | {lat['ratios'][name]:.2f}x |")
        lines.append("")
    if "runtimes" in block:
        lines += ["Milliseconds per network call of the base (median), torch against ONNX Runtime:", "",
                  "| batch | " + " | ".join(str(b) for b in block["runtimes"]) + " |",
                  "|---|" + "---|" * len(block["runtimes"])]
        for r in ("torch", "onnx"):
            lines.append(f"| {r} | " + " | ".join(f"{v[r]:.2f}" for v in block["runtimes"].values()) + " |")
        lines.append("")
    paper = block.get("paper")
    if paper:
        lines += [f"Paper-size SCDP (freshly initialised weights of the paper preset's size; its own sampler "
                  f"{paper['sampler']} is the default), batch 1, {paper['threads']} threads, median of "
                  f"{paper['trajectories']} trajectories of {paper['chunks']} chunks, the robot taking every planned action:", "",
                  "| planner | trajectory s | cold chunk s | warm chunk s | chunk starts | default torch / this |",
                  "|---|---|---|---|---|---|"]
        for name, r in paper["planners"].items():
            starts = ", ".join(f"{k} {v}" for k, v in sorted(r["starts"].items()))
            warm = "–" if r["warm_chunk_s"] != r["warm_chunk_s"] else f"{r['warm_chunk_s']:.3f}"
            lines.append(f"| {name} | {r['trajectory_s']:.3f} | {r['cold_chunk_s']:.3f} | {warm} | {starts} | {r['ratio']:.1f}x |")
        lines.append("")
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", type=Path, default=Path("results/cpu"), help="a reproduction (its <task>/checkpoints)")
    p.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    p.add_argument("--methods", nargs="+", default=["dp", "scdp", "scdp_legible", "scdp_efficient", "scdp_blend"])
    p.add_argument("--steps", type=int, default=8, help="the fast planner's DDPM steps (default 8)")
    p.add_argument("--warm-skip", type=int, default=4, help="the fast planner's warm-start step (default 4)")
    p.add_argument("--scenes", type=int, default=100, help="validation scenes per set (default 100; 0: latency only)")
    p.add_argument("--latency-scenes", type=int, default=20,
                   help="scenes timed at batch 1 (default 20; 0: the gate only, e.g. beside other work)")
    p.add_argument("--null", action="store_true",
                   help="the gate's null check: the default planner against itself with other noise (no fast planner)")
    p.add_argument("--paper-trajectories", type=int, default=0,
                   help="paper-size trajectories timed at batch 1 per planner (default 0: none; 3 takes minutes)")
    p.add_argument("--seed", type=int, default=2, help="validation scene seed (default 2)")
    p.add_argument("--out", type=Path, default=Path("results/benchmarks/realtime"), help="writes OUT.json and OUT.md")
    args = p.parse_args(argv)
    fast = PlanningOptions() if args.null else PlanningOptions(sampler="ddpm", steps=args.steps, warm_skip=args.warm_skip)
    t0 = time.perf_counter()
    result = {"command": "python benchmarks/realtime.py " + " ".join(argv if argv is not None else sys.argv[1:]),
              "fast": {"steps": args.steps, "warm_skip": args.warm_skip}, "scenes": args.scenes, "null": args.null,
              "gflops": matmul_gflops(), "tasks": {}}
    for name in args.tasks:
        task, checkpoints = get_task(name), args.run / name / "checkpoints"
        result["tasks"][name] = {}
        if args.scenes:
            result["tasks"][name]["gate"] = gate(task, checkpoints, args.methods, fast, args.scenes, args.seed,
                                                   "/redraw" if args.null else "")
        exported = (checkpoints / "base" / "model.onnx").is_file()
        if args.latency_scenes:  # 0: the gate only (its numbers do not depend on the machine's load)
            result["tasks"][name]["latency"] = latency(task, checkpoints, fast, args.latency_scenes, args.seed,
                                                       ("torch", "onnx") if exported else ("torch",))
        if args.latency_scenes and exported:  # where --runtime auto should switch
            result["tasks"][name]["runtimes"] = runtime_crossover(checkpoints, task)
        if args.paper_trajectories:
            with tempfile.TemporaryDirectory(prefix="scdp-paper-onnx-") as work:
                result["tasks"][name]["paper"] = paper_latency(task, fast, args.paper_trajectories, args.seed, Path(work))
    result["compute_minutes"] = (time.perf_counter() - t0) / 60
    write_json(args.out.with_suffix(".json"), result)
    write_text(args.out.with_suffix(".md"), markdown(result))
    print(markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
