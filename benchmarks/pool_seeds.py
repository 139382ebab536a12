"""Pool the cpu reproduction over training seeds: per-seed targets, pooled targets, spread.

Regenerates: `results/cpu/confirmation/pooled.md`, `results/cpu/confirmation_observers/pooled.json`

    python benchmarks/pool_seeds.py --runs results/cpu runs/cpu_seed1 runs/cpu_seed2 --seeds 0 1 2 \
        [--out results/cpu/seeds] [--targets style|observers] [--keep-paths]

Each run is the output folder of ``scdp reproduce --task all --preset cpu --seed K``, or a
``seed_K.json`` this script wrote before (so a seed whose run folder is gone still pools). Every
seed evaluates the same scenes with the same noise (scene and evaluation seeds do not change
with ``--seed``), so the seeds differ only in what was trained (the networks, and the
demonstrations where a run also set ``data.seed``). ``--commit`` records the code the runs used
in every file written. Writes, into ``--out``:

* ``seed_K.json``: the random-scene records of seed K without their paths (small enough to
  commit; the pooled numbers are recomputed from them); with ``--keep-paths``,
  ``seed_K.json.gz``: every record whole, path, goals, target, task, method, scene set and
  scene index included, so that anyone can re-score the runs with another observer;
* ``pooled.json`` / ``pooled.md``: each target per seed and pooled, whether it points the same
  way on every seed, and each method's mean T and success per seed with their spread
  (max - min) across seeds. ``--targets style``: issue 9's (:mod:`scdp.evaluation.targets`);
  ``--targets observers``: issue 36's (:mod:`scdp.evaluation.observer_targets`), with the
  adaptivity shares (:mod:`scdp.evaluation.adaptivity`) pooled beside them.

Pooling: the seeds roll out the *same* scenes, so K seeds are not K times as many scenes. Each
pooled record carries its ``training_seed``: pairs stay within a seed, and the bootstrap of
:func:`scdp.evaluation.statistics.compare` resamples scenes, each drawn scene bringing its pairs
of every seed (seeds nested within scenes), not the pairs one by one.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from scdp.evaluation.adaptivity import adaptivity, adaptivity_markdown
from scdp.evaluation.observer_targets import observer_targets, observer_targets_markdown
from scdp.evaluation.records import FAILURE_AWARE, load_records, record_value
from scdp.evaluation.statistics import comparisons_markdown, paired_comparisons
from scdp.evaluation.targets import targets
from scdp.io import read_json, write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR


def slim(records) -> list[dict]:
    return [{**r.to_dict(), "path": [], "goals": []} for r in records]


TARGETS = {"style": targets, "observers": observer_targets}


def headline(value) -> float:
    """The number a target is judged on: a difference's mean, a share, or the lowest success."""
    if isinstance(value, dict) and "difference" in value:
        return value["difference"][0]
    if isinstance(value, dict) and "legible_minus_efficient_d_hat" in value:
        return value["legible_minus_efficient_d_hat"][0]
    for key in ("mean", "share"):
        if isinstance(value, dict) and key in value:
            return value[key]
    floats = [v for v in value.values() if isinstance(v, float)]
    return min(floats) if floats else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", nargs="+", type=Path, required=True,
                        help="reproduction folders (or earlier seed_K.json files), one per seed")
    parser.add_argument("--seeds", nargs="+", type=int, required=True, help="the training seed of each run")
    parser.add_argument("--out", type=Path, default=Path("results/cpu/seeds"))
    parser.add_argument("--title", default="The cpu reproduction over training seeds", help="heading of pooled.md")
    parser.add_argument("--targets", choices=sorted(TARGETS), default="style",
                        help="style: issue 9's D̂ and T targets; observers: issue 36's observer and adaptivity targets")
    parser.add_argument("--keep-paths", action="store_true", help="write every record whole as seed_K.json.gz")
    parser.add_argument("--commit", help="the commit the runs used (recorded in every file written)")
    args = parser.parse_args()
    if len(args.runs) != len(args.seeds):
        parser.error("--runs and --seeds must have the same length")
    per_seed, pooled = {}, []
    for run, seed in zip(args.runs, args.seeds):
        source = run if run.is_file() else run / "results.json"
        origin = read_json(source).get("run", str(run)) if run.is_file() else str(run)
        records = [r for r in load_records(source) if r.protocol in (None, "random")
                   and r.scene_set in (AMBIGUOUS, CLEAR)]
        if args.keep_paths:
            write_json(args.out / f"seed_{seed}.json.gz", {"seed": seed, "run": origin, "commit": args.commit,
                                                                 "trajectories": [r.to_dict() for r in records]},
                       compact=True)
        else:
            write_json(args.out / f"seed_{seed}.json", {"seed": seed, "run": origin, "commit": args.commit, "trajectories": slim(records)},
                       compact=True)
        per_seed[seed] = records
        pooled += [replace(r, training_seed=seed) for r in records]
    judge = TARGETS[args.targets]
    judged = {seed: judge(records) for seed, records in per_seed.items()}
    rows = []
    for i, t in enumerate(judge(pooled)):
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
                t_fa = [float(np.mean([record_value(r, FAILURE_AWARE) for r in per_seed[k]
                                       if (r.task, r.scene_set, r.method) == (task, s, m)])) for k in per_seed]
                ok = [float(np.mean([r.success for r in per_seed[k] if (r.task, r.scene_set, r.method) == (task, s, m)])) for k in per_seed]
                means[f"{task}/{s}/{m}"] = {"T": [round(v, 3) for v in t], "T_spread": round(max(t) - min(t), 3),
                                            "T_fa": [round(v, 3) for v in t_fa], "success": [round(v, 3) for v in ok]}
    comparisons = paired_comparisons(pooled, (AMBIGUOUS, CLEAR))
    shares = adaptivity(pooled) if args.targets == "observers" else []
    write_json(args.out / "pooled.json", {"seeds": args.seeds, "commit": args.commit, "targets": rows, "means": means,
                                          "paired": comparisons, **({"adaptivity": shares} if shares else {})})
    lines = [f"# {args.title}", "",
             f"Seeds {', '.join(map(str, args.seeds))}; the same scenes and noise for every seed"
             + (f"; code at commit {args.commit}" if args.commit else "") + ". "
             "`python benchmarks/pool_seeds.py --help` regenerates it.", "",
             f"## {'Observer' if args.targets == 'observers' else 'Style-effect'} targets, pooled and per seed", "",
             "Pooled intervals: 95 % bootstrap over scenes, each drawn scene with its pairs of every seed (the seeds "
             "share their scenes, so seeds are nested within scenes).", "",
             "| task | target | pooled holds | pooled numbers | per seed (headline) | holds per seed | spread |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['task']} | {r['target']} | {'yes' if r['holds'] else '**no**'} | `{r['numbers']}` | "
                     f"{', '.join(f'{v:+.3f}' for v in r['per_seed'].values())} | "
                     f"{', '.join('yes' if h else 'no' for h in r['per_seed_holds'])} | {r['spread']} |")
    if args.targets == "observers":
        lines += ["", "### Pooled verdicts with what is reported beside them", "", observer_targets_markdown(rows).rstrip()]
    if shares:
        lines += ["", "## Adaptivity, pooled over seeds (scenes resampled, seeds nested)", "", adaptivity_markdown(shares).rstrip()]
    lines += ["", "## Paired differences, pooled over seeds (scenes resampled, seeds nested)", "",
              comparisons_markdown(comparisons).rstrip()]
    lines += ["", "## Mean T, T_fa and success per seed", "",
              "| task / scene set / method | T per seed | T spread | T_fa per seed | success per seed |", "|---|---|---|---|---|"]
    lines += [f"| {k} | {v['T']} | {v['T_spread']} | {v['T_fa']} | {v['success']} |" for k, v in means.items()]
    write_text(args.out / "pooled.md", "\n".join(lines) + "\n")
    print((args.out / "pooled.md").read_text())


if __name__ == "__main__":
    main()
