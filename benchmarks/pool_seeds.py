"""Pool the cpu reproduction over training seeds: per-seed targets, pooled targets, spread.

    python benchmarks/pool_seeds.py --runs results/cpu runs/cpu_seed1 runs/cpu_seed2 --seeds 0 1 2 \
        [--out results/cpu/seeds]

Each run is the output folder of ``scdp reproduce --task all --preset cpu --seed K``, or a
``seed_K.json`` this script wrote before (so a seed whose run folder is gone still pools). Every
seed evaluates the same scenes with the same noise (scene and evaluation seeds do not change
with ``--seed``), so the seeds differ only in the trained networks. Writes, into ``--out``:

* ``seed_K.json``: the random-scene records of seed K without their paths (small enough to
  commit; the pooled numbers are recomputed from them);
* ``pooled.json`` / ``pooled.md``: each style-effect target (:mod:`scdp.evaluation.targets`)
  per seed and pooled (pairs stay within a seed; the bootstrap resamples all of them), whether
  it points the same way on every seed, and each method's mean T and success per seed with
  their spread (max - min) across seeds.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from scdp.evaluation.records import load_records
from scdp.evaluation.targets import targets
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR

SEED_STRIDE = 1_000_000  # scene indices of seed K are offset by K * SEED_STRIDE when pooled


def slim(records) -> list[dict]:
    return [{**r.to_dict(), "path": [], "goals": []} for r in records]


def headline(value) -> float:
    """The number a target is judged on: a difference's mean, or the lowest success."""
    if isinstance(value, dict) and "difference" in value:
        return value["difference"][0]
    if isinstance(value, dict) and "legible_minus_efficient_d_hat" in value:
        return value["legible_minus_efficient_d_hat"][0]
    return min(v for v in value.values() if isinstance(v, float))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", nargs="+", type=Path, required=True, help="reproduction folders (or earlier seed_K.json files), one per seed")
    parser.add_argument("--seeds", nargs="+", type=int, required=True, help="the training seed of each run")
    parser.add_argument("--out", type=Path, default=Path("results/cpu/seeds"))
    args = parser.parse_args()
    if len(args.runs) != len(args.seeds):
        parser.error("--runs and --seeds must have the same length")
    per_seed, pooled = {}, []
    for run, seed in zip(args.runs, args.seeds):
        source = run if run.is_file() else run / "results.json"
        origin = json.loads(source.read_text()).get("run", str(run)) if run.is_file() else str(run)
        records = [r for r in load_records(source) if r.protocol in (None, "random")
                   and r.scene_set in (AMBIGUOUS, CLEAR)]
        write_json(args.out / f"seed_{seed}.json", {"seed": seed, "run": origin, "trajectories": slim(records)}, compact=True)
        per_seed[seed] = records
        pooled += [replace(r, scene_index=r.scene_index + seed * SEED_STRIDE) for r in records]
    judged = {seed: targets(records) for seed, records in per_seed.items()}
    rows = []
    for i, t in enumerate(targets(pooled)):
        values = [headline(judged[s][i]["numbers"]) for s in per_seed]
        signs = {bool(judged[s][i]["holds"]) for s in per_seed}
        rows.append({**t, "per_seed": dict(zip(map(str, per_seed), values)), "per_seed_holds": [judged[s][i]["holds"] for s in per_seed],
                     "same_verdict_every_seed": len(signs) == 1, "spread": round(max(values) - min(values), 3)})
    methods = sorted({r.method for r in pooled})
    means = {}
    for task in sorted({r.task for r in pooled}):
        for s in (AMBIGUOUS, CLEAR):
            for m in methods:
                t = [float(np.mean([r.metrics["transparency"] for r in per_seed[k] if (r.task, r.scene_set, r.method) == (task, s, m)]))
                     for k in per_seed]
                ok = [float(np.mean([r.success for r in per_seed[k] if (r.task, r.scene_set, r.method) == (task, s, m)])) for k in per_seed]
                means[f"{task}/{s}/{m}"] = {"T": [round(v, 3) for v in t], "T_spread": round(max(t) - min(t), 3),
                                            "success": [round(v, 3) for v in ok]}
    write_json(args.out / "pooled.json", {"seeds": args.seeds, "targets": rows, "means": means})
    lines = ["# The cpu reproduction over training seeds", "",
             f"Seeds {', '.join(map(str, args.seeds))}; the same scenes and noise for every seed. "
             "`python benchmarks/pool_seeds.py --help` regenerates it.", "",
             "## Style-effect targets, pooled (paired 95 % intervals over every seed's pairs) and per seed", "",
             "| task | target | pooled holds | pooled numbers | per seed (headline) | holds per seed | spread |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['task']} | {r['target']} | {'yes' if r['holds'] else '**no**'} | `{r['numbers']}` | "
                     f"{', '.join(f'{v:+.3f}' for v in r['per_seed'].values())} | "
                     f"{', '.join('yes' if h else 'no' for h in r['per_seed_holds'])} | {r['spread']} |")
    lines += ["", "## Mean T and success per seed", "", "| task / scene set / method | T per seed | T spread | success per seed |",
              "|---|---|---|---|"]
    lines += [f"| {k} | {v['T']} | {v['T_spread']} | {v['success']} |" for k, v in means.items()]
    write_text(args.out / "pooled.md", "\n".join(lines) + "\n")
    print((args.out / "pooled.md").read_text())


if __name__ == "__main__":
    main()
