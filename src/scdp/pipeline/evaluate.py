"""The evaluation stage of ``scdp reproduce``: every method of the preset rolled out on the scene
sets, skipped when ``trajectories.json`` (or, in a fresh clone, the run's ``results.json``) recorded
exactly today's settings and inputs.

Its inputs (:meth:`EvaluationStage.inputs`) are the evaluation's settings (methods, scenes, seed,
sampler, LD's guidance, SCDP's arbitration: :func:`evaluation_settings`) by digest, the task, and
every model set's demos and weights and the scene encoder by content.
"""

from __future__ import annotations

from pathlib import Path

from scdp.config import PlanningOptions, Preset
from scdp.content import digest
from scdp.data.scenes import layout_scenes
from scdp.evaluation.protocol import DATASET, evaluate_methods, scene_sets
from scdp.io import read_json_object, write_json
from scdp.keys import PAPER_METHOD, PER_LAYOUT, RANDOM, layout_number, style_part
from scdp.pipeline.fingerprints import evaluation_inputs
from scdp.pipeline.names import StageName, evaluation_key
from scdp.pipeline.stages import ModelSet, Stage, demos_regenerate
from scdp.policies.loaders import load_method
from scdp.tasks import Task
from scdp.training.recipe import model_parts


def preset_planners(p: Preset, checkpoints: Path, task: Task, device: str = "cpu", encoder_dir: Path | None = None) -> dict:
    """Every method the preset evaluates, loaded from ``checkpoints``, and the Dataset row (None):
    with the preset's sampler, LD guidance and SCDP arbitration, not the ones saved at training time,
    so that retuning any of them re-evaluates without retraining."""
    planning = PlanningOptions(sampler=p.base.model.sampler, steps=p.base.model.num_inference_steps, device=device)
    planners = {m: load_method(m, checkpoints, task, planning, encoder_dir=encoder_dir, guidance=p.ld.guidance,
                               arbitration=p.style_section(style_part("legible", m if m == PAPER_METHOD else "scdp")).arbitration)
                for m in p.evaluation.methods}
    return {**planners, DATASET: None}


def evaluation_settings(preset: Preset, protocol: str, sets: list[ModelSet]) -> dict:
    """What an evaluation is run with, besides its models: written beside its records."""
    ev = preset.evaluation
    settings = {"preset": preset.name, "overrides": list(preset.overrides or ()), "methods": list(ev.methods),
                "layout_repeats": ev.layout_repeats, "seed": ev.seed, "ld_guidance": preset.ld.guidance.to_dict(),
                "arbitration": preset.style.arbitration, "paper_arbitration": preset.paper_style.arbitration,
                "sampler": [preset.base.model.sampler, preset.base.model.num_inference_steps]}
    if protocol == PER_LAYOUT:
        return {**settings, "layouts": [s.scenes for s in sets]}
    goals = preset.data.goals
    return {**settings, "eval_scenes": ev.scenes, **({"goals": goals} if goals != 2 else {})}


class EvaluationStage(Stage):
    """Roll out each model set: the random-scene set on the random scene sets and the six layouts,
    or (``per_layout``) each per-layout set on its own layout."""

    def __init__(self, main: ModelSet, sets: list[ModelSet], protocol: str = RANDOM):
        """``main``: the task's random-scene model set (its folder holds the evaluation); ``sets``:
        the model sets rolled out (``[main]``, or the per-layout sets)."""
        self.sets, self.protocol, self.ms = sets, protocol, main
        self.name = StageName("evaluate", protocol)
        self.path = main.folder / ("trajectories.json" if protocol == RANDOM else f"{PER_LAYOUT}/trajectories.json")
        self.results = self.ms.folder.parent / "results.json"
        self.key = evaluation_key(self.ms.task.name, protocol)
        self.settings = evaluation_settings(main.preset, protocol, sets)

    def inputs(self) -> dict:
        return evaluation_inputs(self.ms.task, self.sets[0].encoder_dir,
                                 [(ms.scenes, ms.demos_fingerprint(), ms.checkpoints) for ms in self.sets],
                                 model_parts(self.ms.preset), self.settings)

    def demos_regenerate(self) -> bool:
        return all(demos_regenerate(ms) for ms in self.sets)

    def _meta(self) -> dict | None:
        """The recorded evaluation: ``trajectories.json``, else the run's ``results.json`` entry."""
        for read in (self._own, self._merged):
            meta = read()
            if isinstance(meta, dict) and isinstance(meta.get("inputs"), dict):
                return meta
        return None

    def _own(self) -> dict | None:
        return read_json_object(self.path)

    def _merged(self) -> dict | None:
        merged = read_json_object(self.results)
        meta = merged.get("evaluations", {}).get(self.key) if merged is not None else None
        if not isinstance(meta, dict):
            return None
        records = [r for r in merged.get("trajectories", [])
                   if r.get("task") == self.ms.task.name and r.get("protocol") == self.protocol]
        return {**meta, "records": records}

    def recorded(self) -> dict | None:
        meta = self._meta()
        if meta is None:
            return None
        settings = {k: meta.get(k) for k in self.settings}
        return {**meta["inputs"], "settings": digest(settings)}

    def record(self, inputs: dict) -> None:
        meta = self._meta()
        content = {k: v for k, v in inputs.items() if k != "settings"}
        write_json(self.path, {**meta, **self.settings, "inputs": content}, compact=True)

    def refresh(self) -> None:
        if not self.path.exists():  # a fresh clone: the records are committed in results.json
            self.record(self.inputs())
            print(f"[{self.ms.task.name}] {self.name}: {self.path} restored from {self.results}")

    def make(self, inputs: dict) -> None:
        records = []
        for ms in self.sets:
            planners = preset_planners(ms.preset, ms.checkpoints, ms.task, ms.device, ms.encoder_dir)
            records += evaluate_methods(ms.task, planners, self._scenes(ms), seed=ms.preset.evaluation.seed)
        content = {k: v for k, v in inputs.items() if k != "settings"}
        write_json(self.path, {**self.settings, "inputs": content, "task": self.ms.task.name,
                               "records": [r.to_dict() for r in records]}, compact=True)
        print(f"[{self.ms.task.name}] {self.name}: {len(records)} trajectories -> {self.path}")

    def _scenes(self, ms: ModelSet) -> dict:
        ev = ms.preset.evaluation
        if self.protocol == PER_LAYOUT:
            return {ms.scenes: layout_scenes(ms.task, layout_number(ms.scenes), ev.layout_repeats)}
        return scene_sets(ms.task, ev.scenes, ev.seed, ev.layout_repeats, n_goals=ms.preset.data.goals)

    def outputs(self) -> dict:
        return {"trajectories": str(self.path)}
