"""Which ranking of the demonstrations makes a legible style that observers read? (issue 36, part 2)

    python benchmarks/legible_criterion.py [--tasks navigation block_reach] [--scenes 50] [--seed 2] \
        [--run results/cpu] [--work runs/criterion] [--out results/criterion]

The paper ranks the legible predictor's demonstrations by detachment D̂. For every other ranking of
``scdp.keys.LEGIBLE_SCORES`` (Dragan's legibility in task space, and as the task's viewer sees the
motion) the legible predictor is trained again with the cpu preset's settings
(``--set style.legible_score=...``) on the committed run's frozen base, encoder and demonstrations
(``--run``); each is paired with the committed efficient predictor, which no ranking changes. The
detachment row is the committed predictor itself.

Then, on ``--scenes`` ambiguous + ``--scenes`` clear *validation* scenes (seed 2 of the validation
stream: nothing here looks at evaluation scenes), DP, tuned LD, and for each ranking SCDP (auto) and
its forced legible style, with the shared forced efficient style, roll out on the same scenes with the
same noise. Written to ``--out``: ``legible_criterion.json`` (every record, so anyone can re-score
them) and ``legible_criterion.md``: per task and ranking, the forced styles' gap and SCDP − DP on
D̂ and on each observer's accuracy at 50 % of the motion, adaptivity shares, success, and the compute
minutes of training and evaluation.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
import time
from pathlib import Path

from scdp.data.scenes import VALIDATION
from scdp.evaluation.adaptivity import EFFICIENT, LEGIBLE, adaptivity, adaptivity_markdown
from scdp.evaluation.observation import OBSERVERS, measure_all
from scdp.evaluation.protocol import evaluate_methods, scene_sets
from scdp.evaluation.records import TrajectoryRecord, record_value
from scdp.evaluation.statistics import compare_values, success_rate
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR, LEGIBLE_SCORES
from scdp.perception import viewer_camera
from scdp.policies.loaders import load_method
from scdp.tasks import get_task

PAPER = "d_hat"
SHARED = ("base", "encoder", "style_efficient", "ld")  # the committed parts every ranking's folder links to


def train_legible(task: str, run: Path, work: Path, score: str) -> tuple[Path, float]:
    """A checkpoints folder whose legible predictor ranks by ``score``; the committed one for the paper's."""
    if score == PAPER:
        return run / task / "checkpoints", 0.0
    if score == "viewpoint_legibility" and viewer_camera(get_task(task)) is None:
        return train_legible(task, run, work, "legibility")  # watched from above: the same ranking, the same predictor
    folder = work / task / score
    folder.mkdir(parents=True, exist_ok=True)
    for part in SHARED:
        link = folder / part
        if not link.exists():
            link.symlink_to((run / task / "checkpoints" / part).resolve())
    t0 = time.perf_counter()
    config = folder / "style_legible" / "config.json"
    if not (config.exists() and json.loads(config.read_text()).get("complete")):  # trained to the end before
        subprocess.run([sys.executable, "-m", "scdp", "train", "style", "--task", task, "--style", "legible",
                        "--data", str(run / task / "demos.zarr"), "--out", str(folder / "style_legible"),
                        "--base", str(folder / "base"), "--encoder", str(folder / "encoder"),
                        "--set", f"style.legible_score=\"{score}\"", "--force"], check=True)
    return folder, (time.perf_counter() - t0) / 60


def rename(records: list[TrajectoryRecord], names: dict[str, str]) -> list[TrajectoryRecord]:
    return [dataclasses.replace(r, method=names[r.method]) for r in records if r.method in names]


def cell(c: dict) -> str:
    star = "*" if c["lo"] > 0 or c["hi"] < 0 else ""
    return f"{c['mean']:+.3f}{star} [{c['lo']:+.3f}, {c['hi']:+.3f}]"


def analyse(records: list[TrajectoryRecord], score: str) -> dict:
    """One ranking's planners renamed to the report's names (scdp, scdp_legible, scdp_efficient), then
    the forced styles' gap and SCDP − DP in ambiguous scenes, adaptivity and success."""
    names = {"dp": "dp", "ld": "ld", f"scdp[{score}]": "scdp", f"scdp_legible[{score}]": LEGIBLE, EFFICIENT: EFFICIENT}
    own = rename(records, names)
    measured = measure_all(own)
    values = {"d_hat": lambda r: record_value(r, "d_hat")}
    values |= {f"{o}_correct_at_50": measured[o].correct_at(50) for o in OBSERVERS}
    ambiguous = [r for r in own if r.scene_set == AMBIGUOUS]
    gaps = {name: compare_values(ambiguous, LEGIBLE, EFFICIENT, v, name) for name, v in values.items()}
    vs_dp = {name: compare_values(ambiguous, "scdp", "dp", v, name) for name, v in values.items()}
    vs_ld = {name: compare_values(ambiguous, "scdp", "ld", v, name) for name, v in values.items()}
    success = {m: success_rate([r for r in own if r.method == m])["mean"] for m in ("dp", "ld", "scdp", LEGIBLE, EFFICIENT)}
    return {"score": score, "forced_gap": gaps, "scdp_minus_dp": vs_dp, "scdp_minus_ld": vs_ld, "success": success,
            "adaptivity": adaptivity(own, measured, planners=("dp", "ld", "scdp", LEGIBLE, EFFICIENT))}


def markdown(result: dict) -> str:
    lines = ["# The legible predictor's ranking, on validation scenes", "",
             f"Command: `{result['command']}`", "",
             f"{result['scenes']} ambiguous + {result['scenes']} clear validation scenes per task (seed {result['seed']}); "
             "every planner on the same scenes with the same noise; 95 % paired bootstrap intervals, * = excludes zero. "
             "Observers read at 50 % of the motion (docs/observers.md). The frozen base, encoder, efficient predictor and "
             f"tuned LD are the committed run's ({result['run']}).", ""]
    for task, rows in result["tasks"].items():
        lines += [f"## {task}", "", f"Compute: {rows['minutes']}", "",
                  "Ambiguous scenes: forced legible − forced efficient (the style effect), and SCDP − DP, SCDP − LD:", "",
                  "| ranking | measure | legible − efficient | SCDP − DP | SCDP − LD |", "|---|---|---|---|---|"]
        for row in rows["rankings"]:
            for name in row["forced_gap"]:
                lines.append(f"| {row['score']} | {name.replace('_', ' ')} | {cell(row['forced_gap'][name])} | "
                             f"{cell(row['scdp_minus_dp'][name])} | {cell(row['scdp_minus_ld'][name])} |")
        lines += ["", "Success (all scenes): " + "; ".join(
            f"{row['score']}: " + ", ".join(f"{m} {v:.2f}" for m, v in row["success"].items()) for row in rows["rankings"]), ""]
        for row in rows["rankings"]:
            lines += [f"Adaptivity, ranking {row['score']}:", "", adaptivity_markdown(row["adaptivity"]), ""]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    parser.add_argument("--scenes", type=int, default=50, help="validation scenes per set (ambiguous, clear)")
    parser.add_argument("--seed", type=int, default=2, help="validation seed (2: as every ablation)")
    parser.add_argument("--run", type=Path, default=Path("results/cpu"), help="the committed run whose parts stay frozen")
    parser.add_argument("--work", type=Path, default=Path("runs/criterion"), help="where the new predictors are trained")
    parser.add_argument("--out", type=Path, default=Path("results/criterion"))
    args = parser.parse_args()
    result = {"command": "python benchmarks/legible_criterion.py " + " ".join(sys.argv[1:]), "scenes": args.scenes,
              "seed": args.seed, "run": str(args.run), "tasks": {}}
    records_out = []
    for name in args.tasks:
        task = get_task(name)
        folders, minutes = {}, {}
        for score in LEGIBLE_SCORES:
            folders[score], minutes[f"train {score}"] = train_legible(name, args.run, args.work, score)
        t0 = time.perf_counter()
        sets = {k: v for k, v in scene_sets(task, args.scenes, args.seed, stream=VALIDATION).items() if k in (AMBIGUOUS, CLEAR)}
        committed = args.run / name / "checkpoints"
        planners = {"dp": load_method("dp", committed, task), "ld": load_method("ld", committed, task),
                    EFFICIENT: load_method(EFFICIENT, committed, task)}
        for score, folder in folders.items():
            planners[f"scdp[{score}]"] = load_method("scdp", folder, task)
            planners[f"scdp_legible[{score}]"] = load_method(LEGIBLE, folder, task)
        records = evaluate_methods(task, planners, sets, seed=args.seed)
        minutes["evaluate"] = (time.perf_counter() - t0) / 60
        t0 = time.perf_counter()
        rankings = [analyse(records, score) for score in LEGIBLE_SCORES]
        minutes["analyse"] = (time.perf_counter() - t0) / 60
        result["tasks"][name] = {"minutes": ", ".join(f"{k} {v:.1f} min" for k, v in minutes.items()), "rankings": rankings}
        records_out += [r.to_dict() for r in records]
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "legible_criterion.json", {**result, "records": records_out}, compact=True)
    write_text(args.out / "legible_criterion.md", markdown(result))
    print(markdown(result))


if __name__ == "__main__":
    main()
