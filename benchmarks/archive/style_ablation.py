"""How far do SCDP's styles move the paths? One row per (model set, film scale) on validation scenes.

    python benchmarks/style_ablation.py --task navigation --checkpoints runs/abl/nav200/ck --label "cpu preset" \
        [--film-scales 1 2 3] [--scenes 30] [--seed 2] [--out results/cpu/ablation.json]

Scenes: ``--scenes`` ambiguous + ``--scenes`` clear random scenes drawn with ``--seed`` (2 by
default: disjoint from the evaluation scenes of seed 1, so nothing is tuned on them). Every
method runs on the same scenes with the same per-scene noise. A row holds the forced styles'
D̂ and Ê, SCDP (auto), DP's and the Dataset's T, SCDP − DP and SCDP − Dataset with their 95 %
paired bootstrap intervals, the lowest success of any method, and the compute minutes. Rows are appended to ``--out`` (JSON)
and the Markdown table beside it is rewritten from all rows.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from scdp.data.scenes import VALIDATION
from scdp.evaluation.protocol import DATASET, evaluate_methods, scene_sets
from scdp.evaluation.statistics import compare
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.policies.loaders import load_method
from scdp.tasks import get_task

METHODS = ("dp", "scdp_legible", "scdp_efficient", "scdp")


def mean(records, method, scene_set, metric):
    values = [r.metrics[metric] if metric != "success" else float(r.success)
              for r in records if r.method == method and r.scene_set == scene_set]
    return float(np.mean(values))


def row(task, checkpoints, label, film_scale, scenes, seed, style_guidance=0.0, arbitration="ellipse") -> dict:
    t0 = time.perf_counter()
    sets = {k: v for k, v in scene_sets(task, scenes, seed, stream=VALIDATION).items() if k in (AMBIGUOUS, CLEAR)}
    planners = {m: load_method(m, checkpoints, task, film_scale=film_scale, style_guidance=style_guidance if m != "dp" else 0.0,
                               arbitration=arbitration) for m in METHODS}
    records = evaluate_methods(task, {**planners, DATASET: None}, sets, seed=seed, progress=False)
    out = {"task": task.name, "label": label, "checkpoints": str(checkpoints), "film_scale": film_scale,
           "style_guidance": style_guidance, "arbitration": arbitration,
           "scenes_per_set": scenes, "seed": seed}
    for s, tag in ((AMBIGUOUS, "amb"), (CLEAR, "clear")):
        for m in ("scdp_legible", "scdp_efficient"):
            for metric, short in (("d_hat", "D"), ("e_hat", "E")):
                out[f"{m.removeprefix('scdp_')}_{short}_{tag}"] = round(mean(records, m, s, metric), 3)
        for m in ("dp", "scdp", DATASET):
            out[f"{m}_T_{tag}"] = round(mean(records, m, s, "transparency"), 3)
        for other in ("dp", DATASET):
            c = compare([r for r in records if r.scene_set == s], "scdp", other, "transparency")
            out[f"scdp_minus_{other}_T_{tag}"] = [round(c.mean, 3), round(c.lo, 3), round(c.hi, 3)]
    out["gap_D_amb"] = round(out["legible_D_amb"] - out["efficient_D_amb"], 3)
    out["min_success"] = round(min(mean(records, m, s, "success") for m in METHODS for s in sets), 3)
    out["compute_minutes"] = round((time.perf_counter() - t0) / 60, 1)
    return out


COLUMNS = [("label", "model set"), ("film_scale", "film ×"), ("style_guidance", "style guidance"), ("arbitration", "rule"),
           ("legible_D_amb", "leg D amb"), ("efficient_D_amb", "eff D amb"),
           ("gap_D_amb", "gap D amb"), ("legible_E_amb", "leg E amb"), ("efficient_E_amb", "eff E amb"),
           ("legible_D_clear", "leg D clear"), ("efficient_D_clear", "eff D clear"), ("legible_E_clear", "leg E clear"),
           ("efficient_E_clear", "eff E clear"), ("dp_T_amb", "DP T amb"),
           ("scdp_T_amb", "SCDP T amb"), ("scdp_minus_dp_T_amb", "SCDP−DP amb [95 %]"), ("dp_T_clear", "DP T clear"),
           ("scdp_T_clear", "SCDP T clear"), ("scdp_minus_dp_T_clear", "SCDP−DP clear [95 %]"),
           ("dataset_T_amb", "Dataset T amb"), ("scdp_minus_dataset_T_amb", "SCDP−Dataset amb [95 %]"),
           ("dataset_T_clear", "Dataset T clear"), ("scdp_minus_dataset_T_clear", "SCDP−Dataset clear [95 %]"),
           ("scenes_per_set", "scenes"), ("min_success", "min success"),
           ("compute_minutes", "eval min")]


def markdown(rows: list[dict]) -> str:
    lines = ["# Style ablation (validation scenes)", "",
             "Regenerate a row with `python benchmarks/style_ablation.py --task TASK --checkpoints DIR --label LABEL "
             "[--film-scales ...]`; `bash benchmarks/style_ablation.sh` trains every model set and writes every row. Scenes: "
             "validation seed 2 (the evaluation uses seed 1). SCDP−DP and SCDP−Dataset are paired mean differences in T "
             "with their 95 % bootstrap intervals (— : not measured for that row). \"eval min\" is the evaluation's compute "
             "only; the model sets' training minutes were not recorded (on 2 cores a 1680-step base takes about 3 min, a "
             "3360-step base about 6 min, each predictor 1–3 min; `stage_times.json` of the preset's run). Every row of "
             "this table was made with demonstrations that run to the goal; the rows before that change (predictor input, "
             "windows, demos, relative actions, the ellipse, film ×, style guidance) are in "
             "`results/archive/cpu_radius_demos/ablation.md`.", ""]
    for task in dict.fromkeys(r["task"] for r in rows):
        lines += [f"## {task}", "", "| " + " | ".join(h for _, h in COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
        for r in (r for r in rows if r["task"] == task):
            cells = []
            for name, _ in COLUMNS:
                v = r.get(name, "ellipse" if name == "arbitration" else "—")  # "—": not measured for older rows
                cells.append(f"{v[0]:+.3f} [{v[1]:+.3f}, {v[2]:+.3f}]" if isinstance(v, list) else str(v))
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", required=True)
    parser.add_argument("--checkpoints", required=True, type=Path)
    parser.add_argument("--label", required=True)
    parser.add_argument("--film-scales", type=float, nargs="+", default=[1.0])
    parser.add_argument("--style-guidance", type=float, nargs="+", default=[0.0])
    parser.add_argument("--arbitration", default="ellipse", choices=["ellipse", "probabilistic"])
    parser.add_argument("--scenes", type=int, default=30)
    parser.add_argument("--seed", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("results/cpu/ablation.json"))
    args = parser.parse_args()
    task = get_task(args.task)
    rows = json.loads(args.out.read_text()) if args.out.exists() else []
    key = lambda x: (x["task"], x["label"], x["film_scale"], x.get("style_guidance", 0.0), x.get("arbitration", "ellipse"))  # noqa: E731
    for s in args.film_scales:
        for g in args.style_guidance:
            r = row(task, args.checkpoints, args.label, s, args.scenes, args.seed, g, args.arbitration)
            print(json.dumps(r), flush=True)
            rows = [x for x in rows if key(x) != key(r)] + [r]
            write_json(args.out, rows)
            write_text(args.out.with_suffix(".md"), markdown(rows))


if __name__ == "__main__":
    main()
