"""What each stage output of ``scdp reproduce`` is made from, by content: the key on which a stage
is skipped, for every stage in this one module.

A stage's *inputs* are a dict of names to content hashes (:mod:`scdp.content`): the demos'
(:func:`demos_inputs`: the task and the generator's settings, recorded as ``demos.inputs.json``
beside ``demos.zarr``), the ambiguity report's (:func:`ambiguity_inputs`, in ``ambiguity.json``), a
trained part's (:func:`part_inputs`: its made-from record, :mod:`scdp.training.made_from`, written by
the trainer itself, so ``scdp train`` and ``reproduce`` write the same one) and an evaluation's
(:func:`evaluation_inputs`, in ``trajectories.json`` and ``results.json``). The task is its key by
behaviour (:func:`scdp.data.task_key.task_key`). Every stage is skipped exactly when its recorded
inputs equal the current ones, and redone otherwise, its log naming what changed
(:func:`scdp.content.explain`). Outputs written before scdp recorded their inputs are read by
:func:`older_record` alone. File times play no part: touching, copying or checking out a run
changes nothing, and one changed byte of the demos, of a part's weights or of what the task does
redoes what was made from them.
"""

from __future__ import annotations

from pathlib import Path

from scdp.config import Preset
from scdp.content import FORMAT, digest
from scdp.data.dataset import DemoDataset
from scdp.data.task_key import task_key
from scdp.errors import ScdpError
from scdp.tasks import Task
from scdp.training.made_from import made_from, needs, styles_hash, weights_hash


def demos_hash(path: Path) -> str | None:
    """The demonstrations' content fingerprint (None when ``path`` holds no readable dataset)."""
    try:
        return DemoDataset.load(path).fingerprint()
    except ScdpError:
        return None


def generator_settings(preset: Preset, scenes: str) -> dict:
    """The settings of the demos' generator that a model set's demos are made with."""
    settings = {"num_demos": preset.data.num_demos, "seed": preset.data.seed, "scenes": scenes, "goals": preset.data.goals}
    if preset.data.turning:  # older records stay current
        settings |= {"turning": preset.data.turning} | ({"turn_from": preset.data.turn_from}
                                                        if preset.data.turn_from != "start" else {})
    return settings


def demos_inputs(task: Task, preset: Preset, scenes: str) -> dict:
    """What a model set's demos are made from: the task and the generator's settings."""
    return {"format": FORMAT, "task": task_key(task), "generator": digest(generator_settings(preset, scenes))}


def part_inputs(task: Task, preset: Preset, part: str, *, demos: str | None, checkpoints: Path, encoder_dir: Path) -> dict:
    """What ``part`` is made from today (:func:`scdp.training.made_from.made_from`): the demos of
    fingerprint ``demos``, and the base and the style predictors in ``checkpoints`` and the encoder in
    ``encoder_dir`` where the part starts from them."""
    wanted = needs(preset, part)
    return made_from(task, preset, part, demos=demos if "demos" in wanted else None,
                     base=weights_hash(checkpoints / "base") if "base" in wanted else None,
                     encoder=weights_hash(encoder_dir) if "encoder" in wanted else None,
                     styles=styles_hash(checkpoints) if "styles" in wanted else None)


def evaluation_inputs(task: Task, encoder_dir: Path, sets: list[tuple[str, str | None, Path]], parts, settings: dict) -> dict:
    """What an evaluation is made from: the task, the encoder, each rolled-out model set's demos and
    weights (``sets``: (scenes, demos fingerprint, checkpoints folder) each; ``parts``: the parts it
    loads) and its settings."""
    inputs = {"format": FORMAT, "task": task_key(task), "encoder": weights_hash(encoder_dir)}
    for scenes, demos, checkpoints in sets:
        inputs[f"{scenes}/demos"] = demos
        inputs.update({f"{scenes}/{p}": weights_hash(checkpoints / p) for p in parts})
    return {**inputs, "settings": digest(settings)}


def older_record(stage: str, *, preset: Preset, found) -> dict | None:
    """What an output written before scdp recorded its inputs says of them, for ``reproduce --adopt``
    (:func:`scdp.content.adoptable`); None where it says nothing. One home for every such reader:

    * ``"demos"``: ``found`` is the dataset's generator attributes (a dict): the generator's settings;
    * ``"ambiguity"``: ``found`` is the report: the number of random scenes it compared;
    * ``"part"``: ``found`` is the part's ``config.json``: its recipe alone.
    """
    if not isinstance(found, dict):
        return None
    if stage == "demos":
        generator = {"goals": 2, **found}
        return {"format": FORMAT, "generator": digest({k: generator.get(k) for k in generator_settings(preset, "")})}
    if stage == "ambiguity":
        scenes = (found.get("random") or {}).get("scenes")
        return {"format": FORMAT, "scenes": scenes} if scenes is not None else None
    if stage == "part":
        return {"format": FORMAT, "recipe": digest(found["recipe"])} if "recipe" in found else None
    raise ValueError(f"no older record is read for stage {stage!r}")


def ambiguity_inputs(task: Task, preset: Preset) -> dict:
    """What the ambiguity report is made from: the task (its calibrated settings among its fields)
    and the number of random scenes it compares the definitions on."""
    return {"format": FORMAT, "task": task_key(task), "scenes": preset.evaluation.ambiguity_scenes}
