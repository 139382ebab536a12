"""Beyond two goals: SCDP, DP and LD in scenes of 2, 3, 4 and 5 goals, on both tasks.

Regenerates: `results/goals/goal_count.md`

    python benchmarks/goal_count.py --run results/cpu --out results/goals

For each task and each goal count N:

* N = 2 is the cpu reproduction itself: its committed records (``RUN/results.json``) are read,
  nothing is rolled out again;
* N >= 3: N-goal demonstrations are drawn (``data.goals = N``; the same count, seed and Bézier
  family as the cpu run), a scene encoder for N goals is trained, and both style predictors are
  trained on the top ``style_fraction`` of those demos by the N-goal D̂ and Ê, on the cpu run's
  **frozen base** (and LD on its frozen goal-dropout base). The base and LD's base are
  conditioned on the target alone and never see a distractor: their training data has the same
  law for every N, so they are shared, as the paper's frozen backbone is. Each N is then
  evaluated on ``--scenes`` ambiguous and ``--scenes`` non-ambiguous random N-goal scenes of the
  evaluation stream (eq. 3 against the most probable distractor), every method on the same
  scenes with the same noise;
* the fan (:func:`scdp.data.scenes.fan_scene`): three goals 20° apart on an arc, target in the
  middle, rolled out ``--fan-repeats`` times (different start and sampling noise) by the N = 3
  models: a bend away from one neighbour is a bend toward the other.

Outputs in ``--out``: ``records_<task>_<N>.json`` (every record, so each number recomputes),
``goal_count.json`` (the table's numbers and the compute minutes) and ``goal_count.md``. The
trained N-goal parts go to ``--work`` (not committed). Run it with nothing else on the machine.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from scdp.config import PlanningOptions
from scdp.data.dataset import DemoDataset
from scdp.data.generate import generate_demos
from scdp.data.scenes import fan_scene
from scdp.evaluation import observation
from scdp.evaluation.figures import observer_accuracy, save_figure
from scdp.evaluation.protocol import DATASET, evaluate_methods, scene_sets
from scdp.evaluation.records import TrajectoryRecord, summarize
from scdp.evaluation.statistics import compare, compare_values
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.policies.loaders import load_method
from scdp.presets import get_preset
from scdp.tasks import get_task
from scdp.training import parts

METHODS = ("dp", "ld", "scdp", "scdp_blend", "scdp_legible", "scdp_efficient")
TABLE_METHODS = ("dp", "ld", "scdp", "scdp_blend")
METRICS = ("success", "d_hat", "e_hat", "transparency", "transparency_fa", "legibility")
FAN = "fan"


def train_goal_count(task, preset, run: Path, work: Path) -> Path:
    """Demos, encoder and both style predictors for ``preset.data.goals`` goals; the base and LD's
    base linked from the cpu run. Returns the checkpoints folder. Each part is skipped when done."""
    ckpt = work / "checkpoints"
    ckpt.mkdir(parents=True, exist_ok=True)
    for frozen in ("base", "ld"):
        link = ckpt / frozen
        if not link.exists():
            link.symlink_to((run / task.name / "checkpoints" / frozen).resolve(), target_is_directory=True)
    demos = work / "demos.zarr"
    if not demos.exists():
        dataset, report = generate_demos(task, preset.data.num_demos, preset.data.seed, n_goals=preset.data.goals)
        dataset.save(demos)
        print(f"[{task.name} N={preset.data.goals}] {report['demos']} demos", flush=True)
    dataset = DemoDataset.load(demos)
    if not (ckpt / "encoder" / "model.safetensors").exists():
        parts.train_encoder(task, preset, ckpt / "encoder")
    for style in ("legible", "efficient"):
        if not (ckpt / f"style_{style}" / "model.safetensors").exists():
            parts.train_style(task, dataset, f"style_{style}", preset, ckpt / "base", ckpt / "encoder", ckpt / f"style_{style}")
    return ckpt


def roll_out(task, preset, ckpt: Path, sets: dict) -> list[TrajectoryRecord]:
    planning = PlanningOptions(sampler=preset.base.model.sampler, steps=preset.base.model.num_inference_steps)
    planners = {m: load_method(m, ckpt, task, planning, guidance=preset.ld.guidance, arbitration=preset.style.arbitration)
                for m in METHODS}
    planners[DATASET] = None
    return evaluate_methods(task, planners, sets, seed=preset.evaluation.seed)


def summarise(records: list[TrajectoryRecord], scene_set: str) -> dict:
    """Per method: the metrics' means, SCDP's share of legible chunks, both observers' measures,
    and the paired differences against DP; the forced styles' D̂ difference."""
    group = [r for r in records if r.scene_set == scene_set]
    measured = {o: observation.Measured(group, scene_sets=(scene_set,), belief=observation.Belief(o)) for o in observation.OBSERVERS}
    observed = {o: observation.observer_summary(m) for o, m in measured.items()}
    out = {"methods": {}, "against_dp": {}, "forced_styles_d_hat": compare(group, "scdp_legible", "scdp_efficient", "d_hat").row(),
           "observers": {o: {"observer": v["observer"], "beta": v["beta"]} for o, v in observed.items()}}
    for m in sorted({r.method for r in group}):
        mine = [r for r in group if r.method == m]
        s = summarize(mine)
        chunks = [c for r in mine for c in r.styles if c != "none"]  # DP, LD and the dataset choose no style
        out["methods"][m] = {"runs": len(mine), **{k: s[k]["mean"] for k in METRICS},
                             "legible_chunks": chunks.count("legible") / len(chunks) if chunks else None,
                             "observers": {o: v["tasks"][mine[0].task][scene_set][m] for o, v in observed.items()}}
        if m != "dp" and m != DATASET:
            out["against_dp"][m] = {k: compare(group, m, "dp", k).row() for k in ("success", "d_hat", "e_hat", "transparency_fa")}
            for o, mo in measured.items():  # the observers' accuracy at half the motion, paired the same way
                out["against_dp"][m][f"{o}_correct_at_50"] = compare_values(group, m, "dp", mo.correct_at(50), f"{o}_correct_at_50").row()
    return out


def load_records(path: Path) -> list[TrajectoryRecord]:
    data = json.loads(path.read_text())
    return [TrajectoryRecord.from_dict(r) for r in (data["records"] if isinstance(data, dict) else data)]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", default="results/cpu", help="the cpu reproduction whose frozen base, LD and N = 2 records are used")
    p.add_argument("--out", default="results/goals")
    p.add_argument("--work", default="runs/goals", help="where the N-goal demos and parts are trained (default runs/goals)")
    p.add_argument("--goals", type=int, nargs="+", default=[2, 3, 4, 5])
    p.add_argument("--tasks", nargs="+", default=["block_reach", "navigation"])
    p.add_argument("--scenes", type=int, default=100, help="random scenes per set for N >= 3 (default 100, as the cpu run)")
    p.add_argument("--fan-repeats", type=int, default=20)
    p.add_argument("--report-only", action="store_true", help="rewrite goal_count.md and the figures from what --out holds")
    args = p.parse_args(argv)
    run, out, work = Path(args.run), Path(args.out), Path(args.work)
    if args.report_only:
        return write_report(out)
    out.mkdir(parents=True, exist_ok=True)
    meta = json.loads((run / "results.json").read_text())
    base_preset = get_preset(meta["preset"], meta.get("overrides") or [])
    summary_path = out / "goal_count.json"
    summary = json.loads(summary_path.read_text()) if summary_path.exists() else {"command": " ".join(["python", *sys.argv]),
                                                                                    "run": str(run), "tasks": {}}
    cpu_records = None
    for name in args.tasks:
        task = get_task(name)
        for n in args.goals:
            key = f"{name}/{n}"
            if key in summary.get("done", []):
                print(f"[{key}] done, skipped")
                continue
            t0 = time.perf_counter()
            records_path = out / f"records_{name}_{n}.json"
            if n == 2:
                if cpu_records is None:
                    cpu_records = [TrajectoryRecord.from_dict(r) for r in meta["trajectories"]]
                records = [r for r in cpu_records if r.task == name and r.scene_set in (AMBIGUOUS, CLEAR)
                           and r.protocol in (None, "random") and r.method in (*METHODS, DATASET)]
                trained = 0.0
            else:
                preset = base_preset.with_overrides([f"data.goals={n}"])
                ckpt = train_goal_count(task, preset, run, work / name / f"goals_{n}")
                trained = time.perf_counter() - t0
                sets = {k: v for k, v in scene_sets(task, args.scenes, preset.evaluation.seed, n_goals=n).items()
                        if k in (AMBIGUOUS, CLEAR)}
                if n == 3:
                    sets[FAN] = [fan_scene(task, 3)] * args.fan_repeats
                records = roll_out(task, preset, ckpt, sets)
            write_json(records_path, {"task": name, "goals": n, "records": [r.to_dict() for r in records]}, compact=True)
            entry = {"minutes": {"train": round(trained / 60, 1), "total_wall": round((time.perf_counter() - t0) / 60, 1)}}
            summary["tasks"].setdefault(name, {})[str(n)] = entry
            summary.setdefault("done", []).append(key)
            write_json(summary_path, summary)
            print(f"[{key}] {entry['minutes']}", flush=True)
    return write_report(out)


def write_report(out: Path) -> int:
    """Recompute every number of ``goal_count.json`` from the records files (the compute minutes
    are kept), then ``goal_count.md`` and, per goal count, the accuracy curves of each observer
    (``observer_accuracy_N<n>.png``, ``observer_accuracy_demonstration_N<n>.png``)."""
    summary = json.loads((out / "goal_count.json").read_text())
    for name, by_n in summary["tasks"].items():
        for n, entry in by_n.items():
            records = load_records(out / f"records_{name}_{n}.json")
            by_n[n] = {"minutes": entry["minutes"], **{s: summarise(records, s) for s in sorted({r.scene_set for r in records})}}
    write_json(out / "goal_count.json", summary)
    write_text(out / "goal_count.md", markdown(summary))
    counts = sorted({int(n) for by_n in summary["tasks"].values() for n in by_n})
    for n in counts:
        records = [r for path in sorted(out.glob(f"records_*_{n}.json")) for r in load_records(path)
                   if r.method in (*TABLE_METHODS, DATASET)]
        for observer in observation.OBSERVERS:
            fig = observer_accuracy(observation.observer_summary(observation.Measured(records, belief=observation.Belief(observer))))
            fig.suptitle(f"{n} goals per scene: {fig._suptitle.get_text()}")
            suffix = "" if observer == observation.PATH_LENGTH else f"_{observer}"
            save_figure(fig, out / f"observer_accuracy{suffix}_N{n}.png")
    return 0


def _ci(c: dict) -> str:
    star = "*" if c["lo"] > 0 or c["hi"] < 0 else ""
    return f"{c['mean']:+.3f} [{c['lo']:+.3f}, {c['hi']:+.3f}]{star}"


def _num(v) -> str:
    return "–" if v is None else f"{v:.2f}"


def _pct(v) -> str:
    return "–" if v is None or (isinstance(v, float) and np.isnan(v)) else f"{100 * v:.0f} %"


def markdown(summary: dict) -> str:
    lines = ["# Beyond two goals", "",
             f"Command: `{summary['command']}`. N = 2 rows are the cpu reproduction's own records ({summary['run']}); "
             "N ≥ 3 share its frozen base and LD base and train the scene encoder and both style predictors on N-goal "
             "demos (docs/goals.md). Observers (docs/observers.md): **PL**, the path-length observer of Dragan & Srinivasa, "
             "β = 4; **demo**, the demonstration observer, β = 20; both scale-free, confident at P(g*) ≥ 0.8 held to the end. "
             "'never' is the never-confident share, kept apart from the median time to confidence of the confident runs. "
             "Differences are paired on the same scenes and noise, 95 % bootstrap intervals; * excludes zero.", ""]
    head = ("| N | method | runs | success | D̂ | Ê | T | legible chunks | PL never | PL time to conf. | PL acc. 25/50/75 % "
            "| demo never | demo acc. 25/50/75 % | Δ success vs DP | Δ D̂ vs DP | Δ T_fa vs DP | Δ PL acc. 50 % vs DP "
            "| Δ demo acc. 50 % vs DP |")
    for name, by_n in summary["tasks"].items():
        ordered = sorted(by_n.items(), key=lambda kv: int(kv[0]))
        for scene_set in (AMBIGUOUS, CLEAR):
            lines += [f"## {name}, {scene_set} scenes", "", head, "|" + "---|" * (head.count("|") - 1)]
            for n, entry in ordered:
                block = entry.get(scene_set)
                for m in (*TABLE_METHODS, DATASET) if block else ():
                    row = block["methods"].get(m)
                    if row is None:
                        continue
                    pl, demo = row["observers"]["path_length"], row["observers"]["demonstration"]
                    diff = block["against_dp"].get(m)
                    keys = ("success", "d_hat", "transparency_fa", "path_length_correct_at_50", "demonstration_correct_at_50")
                    cells = [_ci(diff[k]) for k in keys] if diff else [""] * len(keys)
                    lines.append(f"| {n} | {m} | {row['runs']} | {row['success']:.2f} | {row['d_hat']:.3f} | {row['e_hat']:.3f} "
                                 f"| {row['transparency']:.3f} | {_pct(row['legible_chunks'])} | {_pct(pl['never_confident'])} "
                                 f"| {_num(pl['time_to_confidence_median'])} | {_accuracy(pl)} | {_pct(demo['never_confident'])} "
                                 f"| {_accuracy(demo)} | " + " | ".join(cells) + " |")
            lines.append("")
        lines += [f"### {name}: SCDP's forced styles, D̂(legible) − D̂(efficient), ambiguous scenes", "",
                  "| N | pairs | difference [95 % CI] |", "|---|---|---|"]
        lines += [f"| {n} | {e[AMBIGUOUS]['forced_styles_d_hat']['n']} | {_ci(e[AMBIGUOUS]['forced_styles_d_hat'])} |" for n, e in ordered]
        lines.append("")
        fan = by_n.get("3", {}).get(FAN)
        if fan:
            lines += [f"### {name}: the fan (3 goals 20° apart, target in the middle, N = 3 models)", "",
                      "| method | runs | success | D̂ | legibility (PL) | legible chunks | PL never | PL acc. 25/50/75 % "
                      "| demo never | demo acc. 25/50/75 % |", "|---|---|---|---|---|---|---|---|---|---|"]
            for m, row in fan["methods"].items():
                pl, demo = row["observers"]["path_length"], row["observers"]["demonstration"]
                lines.append(f"| {m} | {row['runs']} | {row['success']:.2f} | {row['d_hat']:.3f} | {row['legibility']:.3f} "
                             f"| {_pct(row['legible_chunks'])} | {_pct(pl['never_confident'])} | {_accuracy(pl)} "
                             f"| {_pct(demo['never_confident'])} | {_accuracy(demo)} |")
            lines.append("")
        lines += [f"Compute minutes ({name}, wall, N ≥ 3: demos, encoder, two predictors and the evaluation): "
                  + ", ".join(f"N = {n}: {e['minutes']['total_wall']}" for n, e in ordered if int(n) > 2), ""]
    lines += ["Accuracy curves per N: `observer_accuracy_N<n>.png` (PL) and `observer_accuracy_demonstration_N<n>.png` (demo).", ""]
    return "\n".join(lines)


def _accuracy(observer: dict) -> str:
    return " / ".join(f"{100 * observer[f'correct_at_{p}']:.0f}" for p in (25, 50, 75))


if __name__ == "__main__":
    sys.exit(main())
