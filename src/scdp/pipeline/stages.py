"""The stages of ``scdp reproduce``, and when each one may be skipped.

Each stage writes one output and is skipped when that output already exists, is valid for
the preset, and was made from exactly the current contents of its inputs
(:mod:`scdp.pipeline.fingerprints`; file times play no part); so a killed run picks up where
it stopped, and a changed input redoes what was made from it, and nothing else.

Per task, in ``OUT/<task>/``:

1. ``ambiguity``  calibrate and compare the ambiguity definitions (``ambiguity.json/.md``)
                  and draw the ellipse for the first layout (``ellipse.png``)
2. ``encoder``    the scene autoencoder on random scenes (``checkpoints/encoder``), shared by
                  every model set of the task

The random-scene protocol (``--protocol random``, the default) then trains one model set:

3. ``demos``      generate the demonstrations (``demos.zarr``) and draw them (``demos.png``)
4. ``base``, ``style_legible``, ``style_efficient``, ``ld`` (and ``style_paper_legible``,
   ``style_paper_efficient`` when ``scdp_paper`` is evaluated): train each part into
   ``checkpoints/<part>``; a part interrupted mid-training resumes from its last checkpoint.
   A part is up to date when its recipe (:mod:`scdp.training.recipe`) matches the preset's
   and the inputs it recorded (recipe, demos, the weights it starts from) are today's
5. ``evaluate``   roll out DP, LD, SCDP and the dataset on the scene sets (``trajectories.json``)

The authors' per-layout protocol (``--protocol per_layout``) trains one model set per layout
k, in ``per_layout/layout_k/``, from ``preset.layouts.demos`` demos of that layout only, runs
the same stages 3-4 there, and evaluates each set on its own layout
(``per_layout/trajectories.json``). ``--protocol both`` runs both.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from scdp.config import PlanningOptions, Preset
from scdp.data.dataset import DemoDataset
from scdp.data.generate import generate_demos
from scdp.data.scenes import layout_scenes
from scdp.errors import ScdpError
from scdp.evaluation.calibration import ambiguity_report, report_markdown
from scdp.evaluation.figures import plot_demos, plot_ellipse, save_figure
from scdp.evaluation.protocol import DATASET, evaluate_methods, scene_sets
from scdp.io import write_json, write_text
from scdp.keys import LAYOUT_IDS, PAPER_METHOD, PER_LAYOUT, RANDOM
from scdp.pipeline.fingerprints import FORMAT, RECORD, changes, demos_hash, digest, read_record, weights_hash, write_record
from scdp.policies.loaders import load_method
from scdp.tasks import Task
from scdp.training import parts
from scdp.training.recipe import base_dependent, model_parts, part_recipe

SKIPPED = "_skipped"  # key a stage sets in its outputs when its output was already valid


@dataclass(frozen=True)
class ModelSet:
    """One set of models (base, two style predictors, LD base) and the demos they learn from.

    The random-scene protocol trains one per task in ``OUT/<task>``; the per-layout protocol
    one per layout in ``OUT/<task>/per_layout/layout_k``. All the sets of a task share its
    scene encoder.
    """

    task: object  # scdp.tasks.Task
    preset: Preset  # for a per-layout set: ``preset.for_layout(k)``
    folder: Path
    encoder_dir: Path
    scenes: str = RANDOM  # the demos' scenes: "random" or "layout_k"
    device: str = "cpu"  # where its networks train and plan (scdp.devices); not part of what they are

    @property
    def checkpoints(self) -> Path:
        return self.folder / "checkpoints"

    @property
    def label(self) -> str:
        return self.task.name if self.scenes == RANDOM else f"{self.task.name}/{self.scenes}"


def demos_stage(ms: ModelSet) -> dict:
    task, preset, path = ms.task, ms.preset, ms.folder / "demos.zarr"
    wanted = {"num_demos": preset.data.num_demos, "seed": preset.data.seed, "scenes": ms.scenes, "goals": preset.data.goals}
    try:
        dataset = DemoDataset.load(path)
        gen = {"goals": 2, **dataset.attrs.get("generator", {})}  # datasets written before N goals hold 2
        valid = dataset.task == task.name and all(gen.get(k) == v for k, v in wanted.items())
    except ScdpError:
        valid = False
    if valid:
        print(f"[{ms.label}] demos: {path} is up to date, skipped")
    else:
        dataset, report = generate_demos(task, preset.data.num_demos, preset.data.seed, scenes=ms.scenes,
                                         n_goals=preset.data.goals)
        dataset.save(path, force=True)
        print(f"[{ms.label}] demos: {report['demos']} demos, {report['failures']} failures redrawn -> {path}")
    figure = ms.folder / "demos.png"
    if not valid or not figure.exists():
        save_figure(plot_demos(dataset, task, 50), figure)
    return {"demos": str(path), "demo_figure": str(figure), SKIPPED: valid}


def ambiguity_stage(ms: ModelSet) -> dict:
    task, preset, path = ms.task, ms.preset, ms.folder / "ambiguity.json"
    try:
        valid = json.loads(path.read_text())["random"]["scenes"] == preset.evaluation.ambiguity_scenes
    except (OSError, ValueError, KeyError, TypeError):
        valid = False
    if valid:
        print(f"[{ms.label}] ambiguity: {path} is up to date, skipped")
    else:
        report = ambiguity_report(task, n_random=preset.evaluation.ambiguity_scenes)
        write_json(path, report)
        write_text(path.with_suffix(".md"), report_markdown(report))
        print(f"[{ms.label}] ambiguity: ellipse agrees with eq. 3 on "
              f"{100 * report['random']['agreement']:.1f} % of {preset.evaluation.ambiguity_scenes} scenes -> {path}")
    figure = ms.folder / "ellipse.png"
    if not figure.exists():
        save_figure(plot_ellipse(task, task.layouts[0], 0), figure)
    return {"ambiguity_report": str(path), "ellipse_figure": str(figure), SKIPPED: valid}


def checkpoint_state(folder: Path, part: str, preset: Preset, inputs: dict | None = None) -> str:
    """'done' (finished with this preset's recipe for the part, from exactly ``inputs``), 'partial'
    (resumable) or 'missing'. The recipe (:func:`scdp.training.recipe.part_recipe`) holds every
    option that changes the part's weights and nothing else: an evaluation-only change keeps it.
    A finished part is 'done' only when the inputs it recorded equal ``inputs`` (:func:`part_inputs`);
    ``inputs=None`` checks the recipe alone."""
    try:
        meta = json.loads((folder / "config.json").read_text())
    except (OSError, ValueError):
        meta = {}
    if not isinstance(meta, dict) or meta.get("part") != part or meta.get("recipe") != part_recipe(preset, part):
        return "missing"  # (re)train from scratch
    if meta.get("complete"):
        if inputs is None:
            return "done"
        return "missing" if changes(read_record(folder), inputs) else "done"
    return "partial" if (folder / "train_state.json").exists() else "missing"


def part_inputs(ms: ModelSet, part: str) -> dict:
    """What a part is made from, by content (:mod:`scdp.pipeline.fingerprints`): its recipe, and
    for the parts trained on demos the demos, the base's weights where it starts from them, the
    encoder's for a style predictor. A changed one means the part must be retrained."""
    inputs = {"format": FORMAT, "recipe": digest(part_recipe(ms.preset, part))}
    if part == "encoder":
        return inputs
    inputs["demos"] = demos_hash(ms.folder / "demos.zarr")
    if base_dependent(ms.preset, part):
        inputs["base"] = weights_hash(ms.checkpoints / "base")
    if part.startswith("style_"):
        inputs["encoder"] = weights_hash(ms.encoder_dir)
    return inputs


def part_folder(ms: ModelSet, part: str) -> Path:
    return ms.encoder_dir if part == "encoder" else ms.checkpoints / part


def adopt_outputs(stages: list) -> list[Path]:
    """Record, for every finished part of ``stages`` (:func:`plan_stages`) that has this preset's
    recipe but no record of its inputs (trained before scdp recorded them), today's inputs, as if
    it had been made from them; before any stage runs, so that nothing retrained in this run is
    taken for an input of an older part. The evaluations are not adopted: they run again.
    Returns the folders adopted."""
    adopted = []
    for name, _, ms in stages:
        part = name.rsplit("/", 1)[-1]
        if part != "encoder" and part not in model_parts(ms.preset):
            continue
        out = part_folder(ms, part)
        if checkpoint_state(out, part, ms.preset) == "done" and read_record(out) is None and out not in adopted:
            write_record(out, part_inputs(ms, part))
            adopted.append(out)
    return adopted


def train_stage(part: str):
    """A stage that trains one checkpoint part, resuming an interrupted run."""

    def stage(ms: ModelSet) -> dict:
        task, preset = ms.task, ms.preset
        out = part_folder(ms, part)
        inputs = part_inputs(ms, part)
        state = checkpoint_state(out, part, preset, inputs)
        if state == "done":
            print(f"[{ms.label}] {part}: {out} is up to date, skipped")
            return {part: str(out), SKIPPED: True}
        if checkpoint_state(out, part, preset) == "done":  # finished with this recipe: an input changed
            print(f"[{ms.label}] {part}: changed since it was trained: {', '.join(changes(read_record(out), inputs))}")
        (out / RECORD).unlink(missing_ok=True)
        resume = state == "partial"
        if part == "encoder":
            parts.train_encoder(task, preset, out, resume=resume, device=ms.device)
        else:
            dataset = DemoDataset.load(ms.folder / "demos.zarr")
            if part in ("base", "ld"):
                parts.train_diffusion(task, dataset, preset, out, ld=part == "ld", resume=resume, device=ms.device,
                                      base_dir=ms.checkpoints / "base")
            else:
                parts.train_style(task, dataset, part, preset, ms.checkpoints / "base", ms.encoder_dir, out, resume=resume,
                                  device=ms.device)
        write_record(out, inputs)
        print(f"[{ms.label}] {part}: trained -> {out}")
        return {part: str(out)}

    return stage


def preset_planners(p: Preset, checkpoints: Path, task: Task, device: str = "cpu", encoder_dir: Path | None = None) -> dict:
    """Every method the preset evaluates, loaded from ``checkpoints``, and the Dataset row (None):
    with the preset's sampler, LD guidance and SCDP arbitration, not the ones saved at training time,
    so that retuning any of them re-evaluates without retraining."""
    planning = PlanningOptions(sampler=p.base.model.sampler, steps=p.base.model.num_inference_steps, device=device)
    planners = {m: load_method(m, checkpoints, task, planning, encoder_dir=encoder_dir, guidance=p.ld.guidance,
                               arbitration=p.style_section("style_paper_" if m == PAPER_METHOD else "style").arbitration)
                for m in p.evaluation.methods}
    return {**planners, DATASET: None}


def evaluation_inputs(sets: list[ModelSet]) -> dict:
    """What an evaluation rolls out, by content: every model set's demos (the Dataset row) and
    weights, and the scene encoder."""
    inputs = {"format": FORMAT, "encoder": weights_hash(sets[0].encoder_dir)}
    for ms in sets:
        inputs[f"{ms.scenes}/demos"] = demos_hash(ms.folder / "demos.zarr")
        inputs.update({f"{ms.scenes}/{p}": weights_hash(ms.checkpoints / p) for p in model_parts(ms.preset)})
    return inputs


def restore_evaluation(path: Path, results: Path, key: str, wanted: dict) -> bool:
    """Write ``path`` back from the run's ``results.json`` when that holds the evaluation ``key``
    made with exactly ``wanted`` (settings and inputs): the records are committed there, not in
    ``path``, so a fresh clone re-runs no rollout. False when it holds no such evaluation."""
    try:
        merged = json.loads(results.read_text())
    except (OSError, ValueError):
        return False
    meta = merged.get("evaluations", {}).get(key) if isinstance(merged, dict) else None
    if not isinstance(meta, dict) or any(meta.get(k) != v for k, v in wanted.items()):
        return False
    task, protocol = key.split("/")
    records = [r for r in merged.get("trajectories", []) if r.get("task") == task and r.get("protocol") == protocol]
    write_json(path, {**meta, "records": records}, compact=True)
    return True


def evaluation_stage(path: Path, sets: list[ModelSet], wanted: dict, scenes_of, results: Path, protocol: str = RANDOM) -> dict:
    """Evaluate each model set on ``scenes_of(ms)``; skip when ``path`` (or, in its absence, the
    run's ``results.json``: :func:`restore_evaluation`) matches ``wanted`` and recorded exactly
    today's models and demos (:func:`evaluation_inputs`)."""
    first = sets[0]
    inputs = evaluation_inputs(sets)
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError):
        meta = {}
    settings = isinstance(meta, dict) and all(meta.get(k) == v for k, v in wanted.items())
    if settings and not changes(meta.get("inputs"), inputs):
        print(f"[{first.task.name}] evaluate: {path} is up to date, skipped")
        return {"trajectories": str(path), SKIPPED: True}
    if not path.exists() and restore_evaluation(path, results, f"{first.task.name}/{protocol}", {**wanted, "inputs": inputs}):
        print(f"[{first.task.name}] evaluate: {path} restored from {results}, up to date, skipped")
        return {"trajectories": str(path), SKIPPED: True}
    if settings:
        print(f"[{first.task.name}] evaluate: changed since it ran: {', '.join(changes(meta.get('inputs'), inputs))}")
    records = []
    for ms in sets:
        planners = preset_planners(ms.preset, ms.checkpoints, ms.task, ms.device, ms.encoder_dir)
        records += evaluate_methods(ms.task, planners, scenes_of(ms), seed=ms.preset.evaluation.seed)
    write_json(path, {**wanted, "inputs": inputs, "task": first.task.name, "records": [r.to_dict() for r in records]}, compact=True)
    print(f"[{first.task.name}] evaluate: {len(records)} trajectories -> {path}")
    return {"trajectories": str(path)}


def _evaluation_meta(preset: Preset, **extra) -> dict:
    ev = preset.evaluation
    return {"preset": preset.name, "overrides": list(preset.overrides or ()), "methods": list(ev.methods),
            "layout_repeats": ev.layout_repeats, "seed": ev.seed, "ld_guidance": preset.ld.guidance.to_dict(),
            "arbitration": preset.style.arbitration, "paper_arbitration": preset.paper_style.arbitration,
            "sampler": [preset.base.model.sampler, preset.base.model.num_inference_steps],
            **extra}


def evaluate_stage(ms: ModelSet) -> dict:
    """The random-scene models on the random scene sets and the six layouts."""
    ev = ms.preset.evaluation
    goals = ms.preset.data.goals
    wanted = _evaluation_meta(ms.preset, eval_scenes=ev.scenes, **({"goals": goals} if goals != 2 else {}))
    return evaluation_stage(ms.folder / "trajectories.json", [ms], wanted,
                            lambda m: scene_sets(m.task, ev.scenes, ev.seed, ev.layout_repeats, n_goals=goals),
                            ms.folder.parent / "results.json")


def per_layout_evaluate_stage(sets: list[ModelSet]):
    """A stage that evaluates each per-layout model set on its own layout."""

    def stage(ms: ModelSet) -> dict:
        ev = ms.preset.evaluation
        wanted = _evaluation_meta(ms.preset, layouts=[s.scenes for s in sets])
        return evaluation_stage(ms.folder / PER_LAYOUT / "trajectories.json", sets, wanted,
                                lambda m: {m.scenes: layout_scenes(m.task, int(m.scenes.removeprefix("layout_")), ev.layout_repeats)},
                                ms.folder.parent / "results.json", PER_LAYOUT)

    return stage


TASK_STAGES = [("ambiguity", ambiguity_stage), ("encoder", train_stage("encoder"))]


def model_set_stages(preset: Preset) -> list:
    """The (name, stage) pairs that make one model set: its demos, then each part it trains."""
    return [("demos", demos_stage)] + [(part, train_stage(part)) for part in model_parts(preset)]


def protocols_of(protocol: str) -> list[str]:
    """The protocols a ``--protocol`` value runs ("both" is random, then per_layout)."""
    return [RANDOM, PER_LAYOUT] if protocol == "both" else [protocol]


def check_protocol_goals(protocol: str, preset: Preset) -> None:
    """Refuse the per-layout protocol with more than two goals per scene: the layouts hold two."""
    if PER_LAYOUT in protocols_of(protocol) and preset.data.goals != 2:
        raise ScdpError("--protocol", f"the per-layout protocol trains on the authors' two-goal layouts; "
                                      f"data.goals={preset.data.goals} needs --protocol random")


def plan_stages(task: Task, preset: Preset, folder: Path, protocol: str = RANDOM, layouts=LAYOUT_IDS, device="cpu") -> list:
    """The (name, stage, model set) triples ``reproduce`` runs for one task, in order."""
    device = str(device)
    check_protocol_goals(protocol, preset)
    main = ModelSet(task, preset, folder, folder / "checkpoints" / "encoder", device=device)
    stages = [(name, fn, main) for name, fn in TASK_STAGES]
    if RANDOM in protocols_of(protocol):
        stages += [(name, fn, main) for name, fn in model_set_stages(preset)] + [("evaluate", evaluate_stage, main)]
    if PER_LAYOUT in protocols_of(protocol):
        sets = [ModelSet(task, preset.for_layout(k), folder / PER_LAYOUT / f"layout_{k}", main.encoder_dir, f"layout_{k}", device)
                for k in layouts]
        for ms in sets:
            stages += [(f"{PER_LAYOUT}/{ms.scenes}/{name}", fn, ms) for name, fn in model_set_stages(ms.preset)]
        stages.append((f"{PER_LAYOUT}/evaluate", per_layout_evaluate_stage(sets), main))
    return stages
