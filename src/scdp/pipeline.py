"""``scdp reproduce``: the paper's pipeline as resumable stages.

Each stage writes one output and is skipped when that output already exists, is valid for
the preset, and is newer than the outputs it was made from; so a killed run picks up where it
stopped, and a retrained model re-runs what depends on it.

Per task, in ``OUT/<task>/``:

1. ``ambiguity``  calibrate and compare the ambiguity definitions (``ambiguity.json/.md``)
                  and draw the ellipse for the first fixed configuration (``ellipse.png``)
2. ``encoder``    the scene autoencoder on random scenes (``checkpoints/encoder``), shared by
                  every model set of the task

The random-scene protocol (``--protocol random``, the default) then trains one model set:

3. ``demos``      generate the demonstrations (``demos.zarr``) and draw them (``demos.png``)
4. ``base``, ``style_legible``, ``style_efficient``, ``ld``: train each part into
   ``checkpoints/<part>``; a part interrupted mid-training resumes from its last checkpoint
5. ``evaluate``   roll out DP, LD, SCDP and the dataset on the scene sets (``trajectories.json``)

The authors' per-configuration protocol (``--protocol per_config``) trains one model set per
fixed configuration k, in ``per_config/config_k/``, from ``preset.config_demos`` demos of that
configuration only, runs the same stages 3-4 there, and evaluates each set on its own
configuration (``per_config/trajectories.json``). ``--protocol both`` runs both.

Then, over all tasks: ``results.json``, the tables, ``figure2``, ``claims.json`` and
``report.md`` in ``OUT`` (see :func:`write_report`).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

from scdp.config import Preset, get_preset
from scdp.errors import ScdpError
from scdp.tasks import TASKS, get_task

SKIPPED = "_skipped"  # key a stage sets in its outputs when its output was already valid
PROTOCOLS = ("random", "per_config", "both")


@dataclass(frozen=True)
class ModelSet:
    """One set of models (base, two style predictors, LD base) and the demos they learn from.

    The random-scene protocol trains one per task in ``OUT/<task>``; the per-configuration
    protocol one per fixed configuration in ``OUT/<task>/per_config/config_k``. All the sets
    of a task share its scene encoder.
    """

    task: object  # scdp.tasks.Task
    preset: Preset  # for a per-configuration set: ``preset.for_config(k)``
    folder: Path
    encoder_dir: Path
    scenes: str = "random"  # the demos' scenes: "random" or "config_k"

    @property
    def checkpoints(self) -> Path:
        return self.folder / "checkpoints"

    @property
    def label(self) -> str:
        return self.task.name if self.scenes == "random" else f"{self.task.name}/{self.scenes}"


def _mtime(path: Path) -> float:
    """When a stage output was written; for a checkpoint folder, its weights file."""
    path = path / "model.safetensors" if (path / "model.safetensors").exists() else path
    return path.stat().st_mtime


def _newer_than_inputs(output: Path, inputs: list[Path]) -> bool:
    """True when ``output`` was written after every existing input."""
    try:
        made = _mtime(output)
    except OSError:
        return False
    return all(_mtime(p) <= made for p in inputs if p.exists())


def _stage_demos(ms: ModelSet) -> dict:
    from scdp.data.dataset import DemoDataset
    from scdp.data.generate import generate_demos
    from scdp.plotting import plot_demos, save_figure

    task, preset, path = ms.task, ms.preset, ms.folder / "demos.zarr"
    wanted = {"num_demos": preset.num_demos, "seed": preset.demo_seed, "scenes": ms.scenes}
    try:
        dataset = DemoDataset.load(path)
        gen = dataset.attrs.get("generator", {})
        valid = dataset.task == task.name and all(gen.get(k) == v for k, v in wanted.items())
    except ScdpError:
        valid = False
    if valid:
        print(f"[{ms.label}] demos: {path} is up to date, skipped")
        skipped = True
    else:
        skipped = False
        dataset, report = generate_demos(task, preset.num_demos, preset.demo_seed, scenes=ms.scenes)
        dataset.save(path, force=True)
        print(f"[{ms.label}] demos: {report['demos']} demos, {report['failures']} failures redrawn -> {path}")
    figure = ms.folder / "demos.png"
    if not valid or not figure.exists():
        save_figure(plot_demos(dataset, task, 50), figure)
    return {"demos": str(path), "demo_figure": str(figure), SKIPPED: skipped}


def _stage_ambiguity(ms: ModelSet) -> dict:
    from scdp.ambiguity import ambiguity_report, report_markdown
    from scdp.io import write_json, write_text
    from scdp.plotting import plot_ellipse, save_figure

    task, preset, path = ms.task, ms.preset, ms.folder / "ambiguity.json"
    try:
        valid = json.loads(path.read_text())["random"]["scenes"] == preset.ambiguity_scenes
    except (OSError, ValueError, KeyError, TypeError):
        valid = False
    if valid:
        print(f"[{ms.label}] ambiguity: {path} is up to date, skipped")
        skipped = True
    else:
        skipped = False
        report = ambiguity_report(task, n_random=preset.ambiguity_scenes)
        write_json(path, report)
        write_text(path.with_suffix(".md"), report_markdown(report))
        print(f"[{ms.label}] ambiguity: ellipse agrees with eq. 3 on "
              f"{100 * report['random']['agreement']:.1f} % of {preset.ambiguity_scenes} scenes -> {path}")
    figure = ms.folder / "ellipse.png"
    if not figure.exists():
        save_figure(plot_ellipse(task, task.fixed_configs[0], 0), figure)
    return {"ambiguity_report": str(path), "ellipse_figure": str(figure), SKIPPED: skipped}


def _checkpoint_state(folder: Path, part: str, preset: Preset, inputs: list[Path] = ()) -> str:
    """'done' (finished with this preset's schedule, after its inputs), 'partial' (resumable)
    or 'missing'."""
    try:
        meta = json.loads((folder / "config.json").read_text())
    except (OSError, ValueError):
        meta = {}
    schedule = {"base": preset.base, "ld": preset.base, "encoder": preset.encoder}.get(part, preset.style)
    if meta.get("part") != part or meta.get("preset") != preset.name or meta.get("train") != schedule.to_dict():
        return "missing"  # (re)train from scratch
    if meta.get("complete"):
        return "done" if _newer_than_inputs(folder, list(inputs)) else "missing"
    return "partial" if (folder / "train_state.json").exists() else "missing"


def _part_inputs(ms: ModelSet, part: str) -> list[Path]:
    """What a part is trained from: a retrained input means the part must be retrained."""
    if part == "encoder":
        return []
    inputs = [ms.folder / "demos.zarr"]
    if part.startswith("style_"):
        inputs += [ms.checkpoints / "base", ms.encoder_dir]
    return inputs


def _train_stage(part: str):
    """A stage that trains one checkpoint part, resuming an interrupted run."""

    def stage(ms: ModelSet) -> dict:
        from scdp.data.dataset import DemoDataset
        from scdp.training import parts

        task, preset = ms.task, ms.preset
        out = ms.encoder_dir if part == "encoder" else ms.checkpoints / part
        state = _checkpoint_state(out, part, preset, _part_inputs(ms, part))
        if state == "done":
            print(f"[{ms.label}] {part}: {out} is up to date, skipped")
            return {part: str(out), SKIPPED: True}
        resume = state == "partial"
        if part == "encoder":
            parts.train_encoder(task, preset, out, resume=resume)
        else:
            dataset = DemoDataset.load(ms.folder / "demos.zarr")
            if part in ("base", "ld"):
                parts.train_diffusion(task, dataset, preset, out, ld=part == "ld", resume=resume)
            else:
                parts.train_style(task, dataset, part.removeprefix("style_"), preset, ms.checkpoints / "base", ms.encoder_dir,
                                  out, resume=resume)
        print(f"[{ms.label}] {part}: trained -> {out}")
        return {part: str(out)}

    return stage


MODEL_PARTS = ("base", "style_legible", "style_efficient", "ld")


def _evaluation_stage(path: Path, sets: list[ModelSet], wanted: dict, scene_sets) -> dict:
    """Evaluate each model set on ``scene_sets(ms)``; skip when ``path`` matches ``wanted`` and
    is newer than every model it rolled out."""
    from scdp.evaluation.protocol import evaluate_task
    from scdp.io import write_json
    from scdp.policies.checkpoint import load_method

    ms0 = sets[0]
    models = [ms.checkpoints / p for ms in sets for p in MODEL_PARTS] + [ms0.encoder_dir]
    try:
        meta = json.loads(path.read_text())
        valid = all(meta.get(k) == v for k, v in wanted.items()) and _newer_than_inputs(path, models)
    except (OSError, ValueError):
        valid = False
    if valid:
        print(f"[{ms0.task.name}] evaluate: {path} is up to date, skipped")
        return {"trajectories": str(path), SKIPPED: True}
    records = []
    for ms in sets:
        planners = {m: load_method(ms.checkpoints, ms.task, m, encoder_dir=ms.encoder_dir) for m in ("dp", "ld", "scdp")}
        records += evaluate_task(ms.task, planners, scene_sets(ms), seed=ms.preset.eval_seed)
    write_json(path, {**wanted, "task": ms0.task.name, "records": records}, compact=True)
    print(f"[{ms0.task.name}] evaluate: {len(records)} trajectories -> {path}")
    return {"trajectories": str(path)}


def _stage_evaluate(ms: ModelSet) -> dict:
    """The random-scene models on the random scene sets and the six configurations."""
    from scdp.evaluation.protocol import scene_sets

    p = ms.preset
    wanted = {"preset": p.name, "eval_scenes": p.eval_scenes, "config_repeats": p.config_repeats, "seed": p.eval_seed}
    path = ms.folder / "trajectories.json"
    return _evaluation_stage(path, [ms], wanted, lambda m: scene_sets(m.task, p.eval_scenes, p.eval_seed, p.config_repeats))


def _per_config_evaluate(sets: list[ModelSet]):
    """A stage that evaluates each per-configuration model set on its own configuration."""

    def stage(ms: ModelSet) -> dict:
        from scdp.evaluation.protocol import config_scenes

        p = ms.preset
        wanted = {"preset": p.name, "config_repeats": p.config_repeats, "seed": p.eval_seed, "configs": [s.scenes for s in sets]}
        path = ms.folder / "per_config" / "trajectories.json"
        return _evaluation_stage(path, sets, wanted,
                                 lambda m: {m.scenes: config_scenes(m.task, int(m.scenes.removeprefix("config_")), p.config_repeats)})

    return stage


TASK_STAGES = [("ambiguity", _stage_ambiguity), ("encoder", _train_stage("encoder"))]
MODEL_SET_STAGES = [("demos", _stage_demos)] + [(part, _train_stage(part)) for part in MODEL_PARTS]

# Figure 2 draws these fixed configurations: the first ambiguous and a clear one.
FIGURE_SCENES = {"ambiguous": "config_1", "not ambiguous": "config_5"}


def _protocols(protocol: str) -> list[str]:
    return ["random", "per_config"] if protocol == "both" else [protocol]


def plan_stages(task, preset: Preset, folder: Path, protocol: str = "random", configs=range(1, 7)) -> list:
    """The (name, stage, model set) triples ``reproduce`` runs for one task, in order."""
    main = ModelSet(task, preset, folder, folder / "checkpoints" / "encoder")
    stages = [(name, fn, main) for name, fn in TASK_STAGES]
    if "random" in _protocols(protocol):
        stages += [(name, fn, main) for name, fn in MODEL_SET_STAGES] + [("evaluate", _stage_evaluate, main)]
    if "per_config" in _protocols(protocol):
        sets = [ModelSet(task, preset.for_config(k), folder / "per_config" / f"config_{k}", main.encoder_dir, f"config_{k}")
                for k in configs]
        for ms in sets:
            stages += [(f"per_config/{ms.scenes}/{name}", fn, ms) for name, fn in MODEL_SET_STAGES]
        stages.append(("per_config/evaluate", _per_config_evaluate(sets), main))
    return stages


def _stage_times(out: Path) -> dict:
    try:
        return json.loads((out / "stage_times.json").read_text())
    except (OSError, ValueError):
        return {}


TRAJECTORY_FILES = {"random": "trajectories.json", "per_config": "per_config/trajectories.json"}


def _compute_minutes(times: dict, names: list[str]) -> dict:
    """Stage compute per protocol, in minutes: the shared stages count toward ``random``."""
    out = {"random": 0.0, "per_config": 0.0}
    for key, seconds in times.items():
        if key.split("/")[0] in names:
            out["per_config" if "/per_config/" in key else "random"] += seconds / 60
    return {k: round(v, 1) for k, v in out.items()}


def write_report(out: Path, names: list[str], preset: Preset, command: str, protocol: str = "random") -> dict:
    """Merge the tasks' trajectories into results.json; write the tables, figures, claims and report.md.

    Random-scene protocol: Tables 1 and 2, ``figure2``. Per-configuration protocol: Table 3
    (beside the random-scene models when both ran) and ``figure2_per_config``. The claims are
    judged on each protocol that ran.
    """
    from scdp.evaluation import report
    from scdp.io import write_json, write_text
    from scdp.metrics import DEFAULT_BETA
    from scdp.plotting import save_figure

    protocols = _protocols(protocol)
    records = []
    for p in protocols:
        for name in names:
            records += [{**r, "protocol": p} for r in json.loads((out / name / TRAJECTORY_FILES[p]).read_text())["records"]]
    times = _stage_times(out)
    wall = round(sum(v for k, v in times.items() if k.split("/")[0] in names), 2)
    minutes = _compute_minutes(times, names)
    write_json(out / "results.json", {"command": command, "preset": preset.name, "protocols": protocols, "wall_seconds": wall,
                                      "compute_minutes": minutes, "trajectories": records}, compact=True)
    summ = {p: report.summaries([r for r in records if r["protocol"] == p]) for p in protocols}
    write_json(out / "summary_metrics.json", summ)
    judged = []
    lines = [f"# SCDP reproduction ({preset.name} preset)", "", f"Command: `{command}`", "",
             f"Compute time of all stages: {wall} s ({wall / 60:.1f} min): random-scene protocol {minutes['random']} min "
             f"(with the shared ambiguity and encoder stages), per-configuration protocol {minutes['per_config']} min. "
             f"Observer temperature β = {DEFAULT_BETA:g} (scale-free).", ""]
    if "random" in summ:
        for fmt in ("md", "tex"):
            write_text(out / f"table1.{fmt}", report.table1(summ["random"], fmt))
            write_text(out / f"table2.{fmt}", report.table2(summ["random"], fmt))
        _save_figure2(report, [r for r in records if r["protocol"] == "random"], names, out / "figure2", save_figure)
        judged += report.claims(summ["random"])
        lines += ["## Models trained on random scenes", "", report.table1(summ["random"]), "", report.table2(summ["random"]), "",
                  "![Figure 2](figure2.png)", ""]
    if "per_config" in summ:
        for fmt in ("md", "tex"):
            write_text(out / f"table3.{fmt}", report.table3(summ, fmt))
        _save_figure2(report, [r for r in records if r["protocol"] == "per_config"], names, out / "figure2_per_config", save_figure)
        judged += report.claims(summ["per_config"], report.CONFIG_SETS, protocol="per_config")
        lines += ["## The authors' per-configuration protocol", "",
                  f"One model set per fixed configuration, trained on {preset.config_demos} demos of that configuration; "
                  "the random-scene models are evaluated on the same configurations. Ambiguous: configurations 1-3; "
                  "clear: 4-6.", "", report.table3(summ), "", "![Figure 2, per-configuration models](figure2_per_config.png)", ""]
    lines += ["## The paper's claims on our data", "", "| task | models | claim | holds | numbers |", "|---|---|---|---|---|"]
    lines += [f"| {c['task']} | {report.PROTOCOL_NAMES[c['protocol']]} | {c['claim']} | {'yes' if c['holds'] else '**no**'} | "
              f"`{json.dumps(c['numbers'])}` |" for c in judged]
    for p in protocols:
        lines += ["", f"### All metrics, {report.PROTOCOL_NAMES[p]}", "", report.extra_table(summ[p], DEFAULT_BETA)]
    write_text(out / "report.md", "\n".join(lines) + "\n")
    write_json(out / "claims.json", judged)
    return {"results": str(out / "results.json"), "report": str(out / "report.md")}


def _save_figure2(report, records: list[dict], names: list[str], stem: Path, save_figure) -> None:
    fig = report.figure2(records, {n: FIGURE_SCENES for n in names})
    save_figure(fig, stem.with_suffix(".png"))
    save_figure(fig, stem.with_suffix(".pdf"))


def reproduce(task: str, preset: str, out, *, protocol: str = "random", configs=None, command: str = "") -> dict:
    """Run every stage for ``task`` ("all" for both), then the report; write ``OUT/summary.json``.

    ``protocol`` is "random" (models trained on random scenes), "per_config" (the authors' one
    model set per fixed configuration) or "both"; ``configs`` limits the per-configuration
    protocol to some of the six configurations (default all).
    """
    from scdp.io import check_output_path, write_json

    preset_obj = get_preset(preset)
    names = list(TASKS) if task == "all" else [get_task(task).name]
    if protocol not in PROTOCOLS:
        raise ScdpError("--protocol", f"unknown protocol {protocol!r} (choose from {', '.join(PROTOCOLS)})")
    configs = sorted(set(configs or range(1, 7)))
    if any(k not in range(1, 7) for k in configs):
        raise ScdpError("--configs", f"configurations are numbered 1..6, got {configs}")
    out = Path(out)
    check_output_path(out / "summary.json", force=True)
    t0 = time.perf_counter()
    summary = {"command": command, "preset": preset_obj.name, "protocol": protocol, "tasks": {}}
    times = _stage_times(out)
    for name in names:
        folder = out / name
        folder.mkdir(parents=True, exist_ok=True)
        outputs = {}
        for stage, fn, ms in plan_stages(get_task(name), preset_obj, folder, protocol, configs):
            print(f"[{name}] stage {stage} ...", flush=True)
            ts = time.perf_counter()
            result = fn(ms)
            if not result.pop(SKIPPED, False):  # a skipped stage keeps the time it took when it ran
                times[f"{name}/{stage}"] = round(time.perf_counter() - ts, 2)
                write_json(out / "stage_times.json", times)
            if ms.scenes == "random":
                outputs.update({(f"per_config/{k}" if stage.startswith("per_config/") else k): v for k, v in result.items()})
            else:  # one line per per-configuration model set
                outputs[f"per_config/{ms.scenes}"] = str(ms.folder)
        summary["tasks"][name] = outputs
    summary["report"] = write_report(out, names, preset_obj, command, protocol)
    summary["wall_seconds"] = round(time.perf_counter() - t0, 1)
    write_json(out / "summary.json", summary)
    print(f"\ndone in {summary['wall_seconds']} s. Outputs:")
    for name, outputs in summary["tasks"].items():
        for key, value in outputs.items():
            print(f"  {name:12s} {key:24s} {value}")
    for key, value in summary["report"].items():
        print(f"  {'':12s} {key:24s} {value}")
    print(f"  {'':12s} {'summary':24s} {out / 'summary.json'}")
    return summary
