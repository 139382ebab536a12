"""The verdicts of the normalisation confirmation (results/cpu/confirmation_normalisation/PROTOCOL.md).

Regenerates: `results/cpu/confirmation_normalisation/verdicts.json`

    python benchmarks/confirm_normalisation.py --run runs/confirm_normalisation/run --commit C \
        --out results/cpu/confirmation_normalisation [--committed results/cpu/claims.json]

Reads the run's ``claims.json`` (written by ``scdp reproduce``, both readings judged there by
``scdp.pipeline.readings``; nothing is recomputed here but the named cells' verdict words) and writes
into ``--out``: ``verdicts.json`` and ``VERDICTS.md`` (the protocol's named cells under each reading,
confirmed or not, then every claim and target under both readings beside the committed run's
verdicts), ``records.json.gz`` (every record of the random scene sets, whole), and copies of the run's
``report.md``, ``claims.json`` and ``stage_times.json``.
"""

from __future__ import annotations

import argparse
import gzip
import json
import shutil
from pathlib import Path

from scdp.io import read_json, write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR, DATASET_NORMALISATION, NORMALISATIONS, SCENE_NORMALISATION

# (task, scene set, a, b): {normalisation: expected} — the protocol's table, written before the run
NAMED = (
    (("block_reach", AMBIGUOUS, "scdp", "ld"), {SCENE_NORMALISATION: "below 0", DATASET_NORMALISATION: "above 0"}),
    (("block_reach", CLEAR, "scdp", "ld"), {SCENE_NORMALISATION: "below 0", DATASET_NORMALISATION: "above 0"}),
    (("block_reach", AMBIGUOUS, "scdp", "dataset"), {SCENE_NORMALISATION: "above 0", DATASET_NORMALISATION: "above 0"}),
    (("navigation", AMBIGUOUS, "scdp", "dp"), {SCENE_NORMALISATION: "above 0", DATASET_NORMALISATION: "above 0"}),
    (("navigation", CLEAR, "scdp", "ld"), {SCENE_NORMALISATION: "above 0", DATASET_NORMALISATION: "includes 0"}),
)
METRIC = "transparency_fa"
WORD = {True: "holds", False: "missed", None: "not judged"}


def direction(lo: float, hi: float) -> str:
    return "above 0" if lo > 0 else "below 0" if hi < 0 else "includes 0"


def paired_of(claims: dict, normalisation: str) -> list[dict]:
    return claims["paired_differences"] if normalisation == SCENE_NORMALISATION else claims[normalisation]["paired_differences"]


def named_cells(claims: dict) -> list[dict]:
    rows = []
    for (task, scene_set, a, b), expected in NAMED:
        for normalisation in NORMALISATIONS:
            cell = next(r for r in paired_of(claims, normalisation)
                        if (r["task"], r["scene_set"], r["a"], r["b"], r["metric"]) == (task, scene_set, a, b, METRIC))
            found = direction(cell["lo"], cell["hi"])
            rows.append({"task": task, "scene_set": scene_set, "difference": f"{a} − {b}", "normalisation": normalisation,
                         "mean": cell["mean"], "lo": cell["lo"], "hi": cell["hi"], "n": cell["n"],
                         "expected": expected[normalisation], "found": found, "confirmed": found == expected[normalisation]})
    return rows


def verdict_rows(claims: dict, committed: dict | None) -> list[dict]:
    before = {(v["task"], v["protocol"], v["kind"], v["verdict"]): v for v in (committed or {}).get("verdicts", [])}
    rows = []
    for v in claims["verdicts"]:
        old = before.get((v["task"], v["protocol"], v["kind"], v["verdict"]), {})
        rows.append({**v, **{f"committed_{n}": old.get(n) for n in NORMALISATIONS}})
    return rows


def markdown(cells: list[dict], rows: list[dict], commit: str, minutes: float) -> str:
    confirmed = sum(c["confirmed"] for c in cells)
    lines = ["# Normalisation confirmation: verdicts (evaluation seed 59, committed cpu models)", "",
             f"Code: `{commit}` (the protocol's commit). Compute: {minutes:.1f} min of rollouts (the evaluate stages) on 2 cores. "
             f"{confirmed} of {len(cells)} named cells confirmed (PROTOCOL.md: interval on the expected side of zero, or "
             "including zero where no direction was expected). T_fa paired differences, 95 % bootstrap intervals over "
             "scenes.", "", "| task | scene set | difference | reading | mean [95 % CI] | n | expected | found | confirmed |",
             "|---|---|---|---|---|---|---|---|---|"]
    for c in cells:
        lines.append(f"| {c['task']} | {c['scene_set']} | {c['difference']} | {c['normalisation']} | {c['mean']:+.3f} "
                     f"[{c['lo']:+.3f}, {c['hi']:+.3f}] | {c['n']} | {c['expected']} | {c['found']} | "
                     f"{'yes' if c['confirmed'] else '**no**'} |")
    same = sum(all(r[n] == r[f"committed_{n}"] for n in NORMALISATIONS) for r in rows)
    lines += ["", f"## Every claim and target under both readings ({same} of {len(rows)} as on the committed scenes, seed 1)",
              "", "| task | kind | claim or target | per scene (seed 59) | per scene (seed 1) | over the training data (seed 59) "
              "| over the training data (seed 1) |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        cells_ = []
        for n in NORMALISATIONS:
            mark = "" if r[n] == r[f"committed_{n}"] else "**"
            cells_ += [f"{mark}{WORD[r[n]]}{mark}", WORD[r[f"committed_{n}"]]]
        lines.append(f"| {r['task']} | {r['kind']} | {r['verdict']} | " + " | ".join(cells_) + " |")
    lines += ["", "Bold: a verdict that differs from the committed scenes' under the same reading. The observers' "
              "readings and success do not depend on the normalisation."]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", type=Path, required=True, help="the reproduction folder of the confirmation")
    parser.add_argument("--commit", required=True, help="the protocol's commit (recorded)")
    parser.add_argument("--out", type=Path, default=Path("results/cpu/confirmation_normalisation"))
    parser.add_argument("--committed", type=Path, default=Path("results/cpu/claims.json"),
                        help="the committed run's claims.json, whose verdicts are set beside (default %(default)s)")
    args = parser.parse_args()
    claims = read_json(args.run / "claims.json")
    committed = read_json(args.committed) if args.committed.exists() else None
    times = read_json(args.run / "stage_times.json")
    minutes = sum(v for k, v in times.items() if k.endswith("/evaluate")) / 60
    cells, rows = named_cells(claims), verdict_rows(claims, committed)
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "verdicts.json", {"commit": args.commit, "evaluation_seed": 59, "metric": METRIC,
                                            "evaluate_minutes": round(minutes, 1), "named_cells": cells, "verdicts": rows,
                                            "normalisation_ranges": claims.get("normalisation_ranges")})
    write_text(args.out / "VERDICTS.md", markdown(cells, rows, args.commit, minutes))
    results = read_json(args.run / "results.json")
    kept = [r for r in results["trajectories"] if r["scene_set"] in (AMBIGUOUS, CLEAR)]
    tmp = args.out / "records.json.gz.tmp"
    with gzip.open(tmp, "wt") as f:
        json.dump({"commit": args.commit, "normalisation_ranges": results.get("normalisation_ranges"), "records": kept}, f)
    tmp.replace(args.out / "records.json.gz")
    for name in ("report.md", "claims.json", "stage_times.json"):
        shutil.copyfile(args.run / name, args.out / name)
    print(f"{sum(c['confirmed'] for c in cells)} of {len(cells)} named cells confirmed -> {args.out / 'VERDICTS.md'}")


if __name__ == "__main__":
    main()
