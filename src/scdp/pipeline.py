"""``scdp reproduce``: the paper's pipeline as resumable stages.

Each stage writes one output under ``OUT/<task>/`` and is skipped when that output already
exists and is valid, so a killed run picks up where it stopped. Stages so far:

1. ``demos``      generate the demonstrations (``demos.zarr``) and draw them (``demos.png``)
2. ``ambiguity``  calibrate and compare the ambiguity definitions (``ambiguity.json/.md``)
                  and draw the ellipse for the first fixed configuration (``ellipse.png``)
3. ``encoder``, ``base``, ``style_legible``, ``style_efficient``, ``ld``: train each part into
   ``checkpoints/<part>``; a part interrupted mid-training resumes from its last checkpoint.
4. ``evaluate``   roll out DP, LD, SCDP and the dataset on the scene sets (``trajectories.json``)

Then, over all tasks: ``results.json``, ``table1/2.{md,tex}``, ``figure2.{png,pdf}``,
``claims.json`` and ``report.md`` in ``OUT``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from scdp.config import Preset, get_preset
from scdp.errors import ScdpError
from scdp.tasks import TASKS, get_task

SKIPPED = "_skipped"  # key a stage sets in its outputs when its output was already valid


def _stage_demos(task, preset: Preset, folder: Path) -> dict:
    from scdp.data.dataset import DemoDataset
    from scdp.data.generate import generate_demos
    from scdp.plotting import plot_demos, save_figure

    path = folder / "demos.zarr"
    wanted = {"num_demos": preset.num_demos, "seed": preset.demo_seed}
    try:
        dataset = DemoDataset.load(path)
        gen = dataset.attrs.get("generator", {})
        valid = dataset.task == task.name and all(gen.get(k) == v for k, v in wanted.items())
    except ScdpError:
        valid = False
    if valid:
        print(f"[{task.name}] demos: {path} is up to date, skipped")
        skipped = True
    else:
        skipped = False
        dataset, report = generate_demos(task, preset.num_demos, preset.demo_seed)
        dataset.save(path, force=True)
        print(f"[{task.name}] demos: {report['demos']} demos, {report['failures']} failures redrawn -> {path}")
    figure = folder / "demos.png"
    if not valid or not figure.exists():
        save_figure(plot_demos(dataset, task, 50), figure)
    return {"demos": str(path), "demo_figure": str(figure), SKIPPED: skipped}


def _stage_ambiguity(task, preset: Preset, folder: Path) -> dict:
    from scdp.ambiguity import ambiguity_report, report_markdown
    from scdp.io import write_json, write_text
    from scdp.plotting import plot_ellipse, save_figure

    path = folder / "ambiguity.json"
    try:
        valid = json.loads(path.read_text())["random"]["scenes"] == preset.ambiguity_scenes
    except (OSError, ValueError, KeyError, TypeError):
        valid = False
    if valid:
        print(f"[{task.name}] ambiguity: {path} is up to date, skipped")
        skipped = True
    else:
        skipped = False
        report = ambiguity_report(task, n_random=preset.ambiguity_scenes)
        write_json(path, report)
        write_text(path.with_suffix(".md"), report_markdown(report))
        print(f"[{task.name}] ambiguity: ellipse agrees with eq. 3 on "
              f"{100 * report['random']['agreement']:.1f} % of {preset.ambiguity_scenes} scenes -> {path}")
    figure = folder / "ellipse.png"
    if not figure.exists():
        save_figure(plot_ellipse(task, task.fixed_configs[0], 0), figure)
    return {"ambiguity_report": str(path), "ellipse_figure": str(figure), SKIPPED: skipped}


def _checkpoint_state(folder: Path, part: str, preset: Preset) -> str:
    """'done' (finished with this preset's schedule), 'partial' (resumable) or 'missing'."""
    try:
        meta = json.loads((folder / "config.json").read_text())
    except (OSError, ValueError):
        meta = {}
    schedule = {"base": preset.base, "ld": preset.base, "encoder": preset.encoder}.get(part, preset.style)
    if meta.get("part") != part or meta.get("preset") != preset.name or meta.get("train") != schedule.to_dict():
        return "missing"  # (re)train from scratch
    if meta.get("complete"):
        return "done"
    return "partial" if (folder / "train_state.json").exists() else "missing"


def _train_stage(part: str):
    """A stage that trains one checkpoint part, resuming an interrupted run."""

    def stage(task, preset: Preset, folder: Path) -> dict:
        from scdp.data.dataset import DemoDataset
        from scdp.training import parts

        ckpt = folder / "checkpoints"
        out = ckpt / part
        state = _checkpoint_state(out, part, preset)
        if state == "done":
            print(f"[{task.name}] {part}: {out} is up to date, skipped")
            return {part: str(out), SKIPPED: True}
        resume = state == "partial"
        if part == "encoder":
            parts.train_encoder(task, preset, out, resume=resume)
        else:
            dataset = DemoDataset.load(folder / "demos.zarr")
            if part in ("base", "ld"):
                parts.train_diffusion(task, dataset, preset, out, ld=part == "ld", resume=resume)
            else:
                parts.train_style(task, dataset, part.removeprefix("style_"), preset, ckpt / "base", ckpt / "encoder", out, resume=resume)
        print(f"[{task.name}] {part}: trained -> {out}")
        return {part: str(out)}

    return stage


def _stage_evaluate(task, preset: Preset, folder: Path) -> dict:
    from scdp.evaluation.protocol import evaluate_task, scene_sets
    from scdp.io import write_json
    from scdp.policies.checkpoint import load_method

    path = folder / "trajectories.json"
    wanted = {"preset": preset.name, "eval_scenes": preset.eval_scenes, "config_repeats": preset.config_repeats, "seed": preset.eval_seed}
    try:
        meta = json.loads(path.read_text())
        valid = all(meta.get(k) == v for k, v in wanted.items())
    except (OSError, ValueError):
        valid = False
    if valid:
        print(f"[{task.name}] evaluate: {path} is up to date, skipped")
        return {"trajectories": str(path), SKIPPED: True}
    ckpt = folder / "checkpoints"
    planners = {m: load_method(ckpt, task, m) for m in ("dp", "ld", "scdp")}
    sets = scene_sets(task, preset.eval_scenes, preset.eval_seed, preset.config_repeats)
    records = evaluate_task(task, planners, sets, seed=preset.eval_seed)
    write_json(path, {**wanted, "task": task.name, "records": records}, compact=True)
    print(f"[{task.name}] evaluate: {len(records)} trajectories -> {path}")
    return {"trajectories": str(path)}


STAGES = [
    ("demos", _stage_demos),
    ("ambiguity", _stage_ambiguity),
    ("encoder", _train_stage("encoder")),
    ("base", _train_stage("base")),
    ("style_legible", _train_stage("style_legible")),
    ("style_efficient", _train_stage("style_efficient")),
    ("ld", _train_stage("ld")),
    ("evaluate", _stage_evaluate),
]

# Figure 2 draws these fixed configurations: the first ambiguous and a clear one.
FIGURE_SCENES = {"ambiguous": "config_1", "not ambiguous": "config_5"}


def _stage_times(out: Path) -> dict:
    try:
        return json.loads((out / "stage_times.json").read_text())
    except (OSError, ValueError):
        return {}


def write_report(out: Path, names: list[str], preset: Preset, command: str) -> dict:
    """Merge the tasks' trajectories into results.json; write the tables, Figure 2 and report.md."""
    from scdp.evaluation import report
    from scdp.io import write_json, write_text
    from scdp.metrics import DEFAULT_BETA
    from scdp.plotting import save_figure

    records = []
    for name in names:
        records += json.loads((out / name / "trajectories.json").read_text())["records"]
    wall = round(sum(_stage_times(out).values()), 2)
    write_json(out / "results.json", {"command": command, "preset": preset.name, "wall_seconds": wall, "trajectories": records},
               compact=True)
    summ = report.summaries(records)
    write_json(out / "summary_metrics.json", summ)
    for fmt in ("md", "tex"):
        write_text(out / f"table1.{fmt}", report.table1(summ, fmt))
        write_text(out / f"table2.{fmt}", report.table2(summ, fmt))
    fig = report.figure2(records, {n: FIGURE_SCENES for n in names})
    save_figure(fig, out / "figure2.png")
    save_figure(fig, out / "figure2.pdf")
    judged = report.claims(summ)
    lines = [f"# SCDP reproduction ({preset.name} preset)", "", f"Command: `{command}`", "",
             f"Compute time of all stages: {wall} s ({wall / 60:.1f} min). Observer temperature β = {DEFAULT_BETA:g} (scale-free).", "",
             report.table1(summ), "", report.table2(summ), "", "![Figure 2](figure2.png)", "",
             "## The paper's claims on our data", "", "| task | claim | holds | numbers |", "|---|---|---|---|"]
    lines += [f"| {c['task']} | {c['claim']} | {'yes' if c['holds'] else '**no**'} | `{json.dumps(c['numbers'])}` |" for c in judged]
    lines += ["", report.extra_table(summ, DEFAULT_BETA)]
    write_text(out / "report.md", "\n".join(lines) + "\n")
    write_json(out / "claims.json", judged)
    return {"results": str(out / "results.json"), "report": str(out / "report.md")}


def reproduce(task: str, preset: str, out, *, command: str = "") -> dict:
    """Run every stage for ``task`` ("all" for both), then the report; write ``OUT/summary.json``."""
    from scdp.io import check_output_path, write_json

    preset_obj = get_preset(preset)
    names = list(TASKS) if task == "all" else [get_task(task).name]
    out = Path(out)
    check_output_path(out / "summary.json", force=True)
    t0 = time.perf_counter()
    summary = {"command": command, "preset": preset_obj.name, "tasks": {}}
    times = _stage_times(out)
    for name in names:
        folder = out / name
        folder.mkdir(parents=True, exist_ok=True)
        outputs = {}
        for stage, fn in STAGES:
            print(f"[{name}] stage {stage} ...", flush=True)
            ts = time.perf_counter()
            result = fn(get_task(name), preset_obj, folder)
            if not result.pop(SKIPPED, False):  # a skipped stage keeps the time it took when it ran
                times[f"{name}/{stage}"] = round(time.perf_counter() - ts, 2)
                write_json(out / "stage_times.json", times)
            outputs.update(result)
        summary["tasks"][name] = outputs
    summary["report"] = write_report(out, names, preset_obj, command)
    summary["wall_seconds"] = round(time.perf_counter() - t0, 1)
    write_json(out / "summary.json", summary)
    print(f"\ndone in {summary['wall_seconds']} s. Outputs:")
    for name, outputs in summary["tasks"].items():
        for key, value in outputs.items():
            print(f"  {name:12s} {key:18s} {value}")
    for key, value in summary["report"].items():
        print(f"  {'':12s} {key:18s} {value}")
    print(f"  {'':12s} {'summary':18s} {out / 'summary.json'}")
    return summary
