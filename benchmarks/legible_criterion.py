"""Which ranking of the demonstrations makes a legible style that observers read? (issues 36 and 51)

Regenerates: `results/criterion/legible_criterion.md`

    python benchmarks/legible_criterion.py [--tasks navigation block_reach] [--scenes 50] [--seed 2] \
        [--run results/cpu] [--work runs/criterion] [--out results/criterion]

The paper ranks the legible predictor's demonstrations by detachment D̂. For every ranking of
``scdp.keys.LEGIBLE_SCORES`` (D̂; Dragan's legibility in task space and as the task's viewer sees
the motion; ``pareto`` and ``rank_mean``, which ask for D̂ and legibility together) the legible
predictor is trained with the cpu preset's settings (``--set style.legible_score=...``) on the
committed run's frozen base, encoder and demonstrations (``--run``), and paired with the committed
efficient predictor, which no ranking changes. The ranking the committed run was trained with
(:data:`COMMITTED`, the cpu preset's) is the committed predictor itself.

Then, on ``--scenes`` ambiguous + ``--scenes`` clear *validation* scenes (seed 2 of the validation
stream: nothing here looks at evaluation scenes), DP, tuned LD, and for each ranking SCDP (auto) and
its forced legible style, with the shared forced efficient style, roll out on the same scenes with the
same noise. Written to ``--out``: ``legible_criterion.json`` (every record, so anyone can re-score
them), ``legible_criterion.md`` (per task and ranking: the forced styles' gap and SCDP − DP, SCDP − LD
on D̂ and each observer's accuracy at 50 % of the motion, T_fa in both sets, adaptivity, success,
compute minutes; then every ranking's verdict on :data:`TARGETS` and the choice by :data:`RULE`) and
``legible_criterion.png`` (each ranking as a point: D̂ gap against observer gain, with intervals).

Targets and the rule were written here before the run that chose (issue 51) and are not edited after.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
import time
from pathlib import Path

from scdp.cli.parser_common import executor_args
from scdp.data.scenes import VALIDATION
from scdp.evaluation.adaptivity import EFFICIENT, LEGIBLE, adaptivity, adaptivity_markdown
from scdp.evaluation.observation import OBSERVERS, measure_all
from scdp.evaluation.protocol import evaluate_methods, scene_sets
from scdp.evaluation.records import FAILURE_AWARE, TrajectoryRecord, record_value
from scdp.evaluation.statistics import compare_values, success_rate
from scdp.io import held, write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR, LEGIBLE_SCORES
from scdp.perception import viewer_camera
from scdp.pipeline.executor import Unit, make_executor
from scdp.policies.loaders import load_method
from scdp.presets import get_preset
from scdp.tasks import get_task

COMMITTED = get_preset("cpu").style.legible_score  # the ranking results/cpu's legible predictor was trained with
SHARED = ("base", "encoder", "style_efficient", "ld")  # the committed parts every ranking's folder links to
READ = "path_length_correct_at_50"
METHODS = ("dp", "ld", "scdp", LEGIBLE, EFFICIENT)

# Issue 51's targets, per task, written before the run that chose (ambiguous scenes unless said):
TARGETS = {
    "forced legible - efficient D̂ >= 0.30": lambda row: row["forced_gap"]["d_hat"]["mean"] >= 0.30,
    "forced legible - efficient, path-length observer right at 50 % >= +0.10": lambda row: row["forced_gap"][READ]["mean"] >= 0.10,
    "SCDP - tuned LD T_fa: interval not wholly below zero, both scene sets":
        lambda row: all(c["hi"] >= 0 for c in row["t_fa_minus_ld"].values()),
    "SCDP - DP T_fa: interval above zero, both scene sets": lambda row: all(c["lo"] > 0 for c in row["t_fa_minus_dp"].values()),
    "success >= 0.98, every method": lambda row: all(v >= 0.98 for v in row["success"].values()),
}
RULE = ("a ranking meeting every target on both tasks is chosen (several: the larger rule score below); if none does, "
        "the one meeting the most task x target cells, ties broken by the larger rule score: the smaller, over the two "
        "tasks, of min(D̂ gap / 0.30, observer gain / 0.10). The cpu preset adopts the choice only if it differs from "
        "the committed ranking and ranks above it by this rule.")


def rule_key(rows: dict) -> tuple:
    """(targets met over tasks, the rule score) of one ranking: ``rows`` holds its analysed row per task."""
    met = sum(bool(check(row)) for row in rows.values() for check in TARGETS.values())
    score = min(min(row["forced_gap"]["d_hat"]["mean"] / 0.30, row["forced_gap"][READ]["mean"] / 0.10) for row in rows.values())
    return met, score


def choose(result: dict) -> dict:
    """Every ranking's verdict on :data:`TARGETS` and the choice by :data:`RULE`."""
    scores = [row["score"] for row in next(iter(result["tasks"].values()))["rankings"]]
    per = {s: {task: next(r for r in block["rankings"] if r["score"] == s) for task, block in result["tasks"].items()}
           for s in scores}
    verdicts = {s: {task: {name: bool(check(row)) for name, check in TARGETS.items()} for task, row in rows.items()}
                for s, rows in per.items()}
    keys = {s: rule_key(rows) for s, rows in per.items()}
    chosen = max(scores, key=lambda s: keys[s])
    return {"verdicts": verdicts, "keys": {s: list(k) for s, k in keys.items()}, "chosen": chosen,
            "adopt": chosen != COMMITTED and keys[chosen] > keys[COMMITTED], "committed": COMMITTED}


def train_legible(task: str, run: Path, work: Path, score: str) -> tuple[Path, float]:
    """A checkpoints folder whose legible predictor ranks by ``score``; the committed one for :data:`COMMITTED`."""
    if score == COMMITTED:
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
    with held(folder / "style_legible.lock"):  # two units asking for one predictor: the second waits, then finds it
        if not (config.exists() and json.loads(config.read_text()).get("complete")):  # trained to the end before
            subprocess.run([sys.executable, "-m", "scdp", "train", "style", "--task", task, "--style", "legible",
                            "--data", str(run / task / "demos.zarr"), "--out", str(folder / "style_legible"),
                            "--base", str(folder / "base"), "--encoder", str(folder / "encoder"),
                            "--set", f"style.legible_score=\"{score}\"", "--force"], check=True)
    return folder, (time.perf_counter() - t0) / 60


def train_unit(task: str, run: Path, work: Path, score: str, *, report) -> tuple[Path, float]:
    """:func:`train_legible` as a unit of work (scdp.pipeline.executor): one ranking's predictor for one task."""
    trained = train_legible(task, run, work, score)
    report(1)
    return trained


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
    gaps = {name: compare_values(ambiguous, LEGIBLE, EFFICIENT, v, name).row() for name, v in values.items()}
    vs_dp = {name: compare_values(ambiguous, "scdp", "dp", v, name).row() for name, v in values.items()}
    vs_ld = {name: compare_values(ambiguous, "scdp", "ld", v, name).row() for name, v in values.items()}
    success = {m: success_rate([r for r in own if r.method == m])["mean"] for m in METHODS}
    t_fa = {b: {s: compare_values([r for r in own if r.scene_set == s], "scdp", b, lambda r: record_value(r, FAILURE_AWARE),
                                  FAILURE_AWARE).row() for s in (AMBIGUOUS, CLEAR)} for b in ("dp", "ld")}
    clear = [r for r in own if r.scene_set == CLEAR]
    e_hat = compare_values(clear, "scdp", "dp", lambda r: record_value(r, "e_hat"), "e_hat").row()
    return {"score": score, "forced_gap": gaps, "scdp_minus_dp": vs_dp, "scdp_minus_ld": vs_ld, "success": success,
            "e_hat_minus_dp": e_hat,
            "t_fa_minus_dp": t_fa["dp"], "t_fa_minus_ld": t_fa["ld"],
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
        lines += ["", "T_fa, SCDP − DP and SCDP − tuned LD, per scene set:", "",
                  "| ranking | set | SCDP − DP | SCDP − LD |", "|---|---|---|---|"]
        for row in rows["rankings"]:
            for s in row["t_fa_minus_dp"]:
                lines.append(f"| {row['score']} | {s} | {cell(row['t_fa_minus_dp'][s])} | {cell(row['t_fa_minus_ld'][s])} |")
        lines += ["", "Success (all scenes): " + "; ".join(
            f"{row['score']}: " + ", ".join(f"{m} {v:.2f}" for m, v in row["success"].items()) for row in rows["rankings"]), ""]
        for row in rows["rankings"]:
            lines += [f"Adaptivity, ranking {row['score']}:", "", adaptivity_markdown(row["adaptivity"]), ""]
    lines += ["## The trade-off in one table", "",
              "Per task and ranking: the forced styles' gap in ambiguous scenes (D̂; the path-length observer right at "
              "50 %), SCDP − DP and SCDP − tuned LD in T_fa (ambiguous / clear), SCDP − DP in Ê (clear) and in each "
              "observer's accuracy at 50 % (ambiguous: path length / demonstration / viewpoint); means, * = the 95 % "
              "interval excludes zero.", "",
              "| task | ranking | gap D̂ | gap observer | T_fa − DP | T_fa − LD | Ê − DP (clear) | observers − DP |",
              "|---|---|---|---|---|---|---|---|"]

    def m(c: dict) -> str:
        return f"{c['mean']:+.3f}{'*' if c['lo'] > 0 or c['hi'] < 0 else ''}"

    for task, rows in result["tasks"].items():
        for row in rows["rankings"]:
            if "e_hat_minus_dp" not in row:
                continue
            obs = " / ".join(m(row["scdp_minus_dp"][f"{o}_correct_at_50"]) for o in OBSERVERS)
            lines.append(f"| {task} | {row['score']} | {m(row['forced_gap']['d_hat'])} | {m(row['forced_gap'][READ])} | "
                         f"{m(row['t_fa_minus_dp'][AMBIGUOUS])} / {m(row['t_fa_minus_dp'][CLEAR])} | "
                         f"{m(row['t_fa_minus_ld'][AMBIGUOUS])} / {m(row['t_fa_minus_ld'][CLEAR])} | "
                         f"{m(row['e_hat_minus_dp'])} | {obs} |")
    lines.append("")
    choice = result.get("choice")
    if choice:
        names = list(TARGETS)
        lines += ["## Targets (written before the run) and the choice", ""]
        lines += [f"- T{i + 1}: {n}" for i, n in enumerate(names)]
        lines += ["", f"Rule: {RULE}", "",
                  "| ranking | " + " | ".join(f"{t} T{i + 1}" for t in result["tasks"] for i in range(len(names)))
                  + " | cells met | rule score |",
                  "|---|" + "---|" * (len(names) * len(result["tasks"]) + 2)]
        for s, per_task in choice["verdicts"].items():
            marks = ["yes" if per_task[t][n] else "**no**" for t in result["tasks"] for n in names]
            met, score = choice["keys"][s]
            lines.append(f"| {s} | " + " | ".join(marks) + f" | {met} | {score:.2f} |")
        lines += ["", f"Chosen: **{choice['chosen']}** (the committed run ranks by {choice['committed']}); "
                  + ("the cpu preset adopts it." if choice["adopt"] else "the cpu preset keeps its ranking."), "",
                  "![each ranking: D̂ gap against observer gain](legible_criterion.png)", ""]
    return "\n".join(lines) + "\n"


def figure(result: dict, path: Path) -> None:
    """Each ranking as a point per task: forced legible − efficient D̂ gap (x) and path-length observer
    gain at 50 % (y), 95 % intervals as bars, the targets as dashed lines."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    tasks = list(result["tasks"])
    fig, axes = plt.subplots(1, len(tasks), figsize=(5.2 * len(tasks), 4.4), squeeze=False)
    for ax, task in zip(axes[0], tasks):
        for row in result["tasks"][task]["rankings"]:
            d, o = row["forced_gap"]["d_hat"], row["forced_gap"][READ]
            ax.errorbar(d["mean"], o["mean"], xerr=[[d["mean"] - d["lo"]], [d["hi"] - d["mean"]]],
                        yerr=[[o["mean"] - o["lo"]], [o["hi"] - o["mean"]]], fmt="o", capsize=3, label=row["score"])
        ax.axvline(0.30, ls="--", c="grey", lw=0.8)
        ax.axhline(0.10, ls="--", c="grey", lw=0.8)
        ax.axhline(0.0, c="black", lw=0.5)
        ax.set(title=task, xlabel="forced legible − efficient: D̂ gap", ylabel="… path-length observer right at 50 %: gain")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def reanalyse(out: Path) -> None:
    """The report and figure again from the records a run saved: the same analysis, no new rollout."""
    saved = json.loads((out / "legible_criterion.json").read_text())
    records = [TrajectoryRecord.from_dict(r) for r in saved.pop("records")]
    for name, block in saved["tasks"].items():
        own = [r for r in records if r.task == name]
        block["rankings"] = [analyse(own, row["score"]) for row in block["rankings"]]
    if len(saved["tasks"]) > 1:
        saved["choice"] = choose(saved)
    figure(saved, out / "legible_criterion.png")
    write_json(out / "legible_criterion.json", {**saved, "records": [r.to_dict() for r in records]}, compact=True)
    write_text(out / "legible_criterion.md", markdown(saved))
    print(markdown(saved))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    parser.add_argument("--scenes", type=int, default=50, help="validation scenes per set (ambiguous, clear)")
    parser.add_argument("--seed", type=int, default=2, help="validation seed (2: as every ablation)")
    parser.add_argument("--run", type=Path, default=Path("results/cpu"), help="the committed run whose parts stay frozen")
    parser.add_argument("--work", type=Path, default=Path("runs/criterion"), help="where the new predictors are trained")
    parser.add_argument("--out", type=Path, default=Path("results/criterion"))
    executor_args(parser)
    parser.add_argument("--from-json", action="store_true",
                        help="re-analyse the records OUT/legible_criterion.json holds (no training, no rollouts) and "
                             "write the report and figure again")
    args = parser.parse_args()
    if args.from_json:
        reanalyse(args.out)
        return
    result = {"command": "python benchmarks/legible_criterion.py " + " ".join(sys.argv[1:]), "scenes": args.scenes,
              "seed": args.seed, "run": str(args.run), "tasks": {}}
    records_out = []
    executor = make_executor(args.executor, address=args.ray_address, workers=args.workers)
    jobs = [(name, score) for name in args.tasks for score in LEGIBLE_SCORES]  # each a unit: trained side by side
    trained = dict(zip(jobs, executor.run([Unit(f"{name} {score}", train_unit, (name, args.run, args.work, score))
                                           for name, score in jobs])))
    result["executor"] = executor.describe()
    for name in args.tasks:
        task = get_task(name)
        folders, minutes = {}, {}
        for score in LEGIBLE_SCORES:
            folders[score], minutes[f"train {score}"] = trained[name, score]
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
    if len(result["tasks"]) > 1:
        result["choice"] = choose(result)
    args.out.mkdir(parents=True, exist_ok=True)
    figure(result, args.out / "legible_criterion.png")
    write_json(args.out / "legible_criterion.json", {**result, "records": records_out}, compact=True)
    write_text(args.out / "legible_criterion.md", markdown(result))
    print(markdown(result))


if __name__ == "__main__":
    main()
