"""What each stage output of ``scdp reproduce`` was made from, by content: the key on which a stage
is skipped.

A stage's *inputs* are a dict of names to content hashes. A trained part's are its made-from record
(:mod:`scdp.training.made_from`: recipe, task, demos, the weights it starts from), written by the
trainer itself, so ``scdp train`` and ``reproduce`` write the same one. The demos and the ambiguity
report record theirs (:func:`demos_inputs`, :func:`ambiguity_inputs`: the task and the generator's
or calibration's settings) as ``demos.inputs.json`` beside ``demos.zarr`` and as ``ambiguity.json``'s
``inputs``; the evaluation keeps its own in ``trajectories.json`` (and ``results.json``). Every stage
is skipped exactly when its recorded inputs equal the current ones, and redone otherwise, its log
naming the inputs that changed (:func:`~scdp.training.made_from.changes`). File times play no part:
touching, copying or checking out a run changes nothing, and one changed byte of the demos, of a
part's weights or of the task's definition redoes what was made from them.
"""

from __future__ import annotations

from pathlib import Path

from scdp.config import Preset
from scdp.content import FORMAT, digest
from scdp.data.dataset import DemoDataset
from scdp.data.task_key import task_key
from scdp.errors import ScdpError
from scdp.tasks import Task


def demos_hash(path: Path) -> str | None:
    """The demonstrations' content fingerprint (None when ``path`` holds no readable dataset)."""
    try:
        return DemoDataset.load(path).fingerprint()
    except ScdpError:
        return None


def generator_settings(preset: Preset, scenes: str) -> dict:
    """The settings of the demos' generator that a model set's demos are made with."""
    return {"num_demos": preset.data.num_demos, "seed": preset.data.seed, "scenes": scenes, "goals": preset.data.goals}


def demos_inputs(task: Task, preset: Preset, scenes: str) -> dict:
    """What a model set's demos are made from: the task and the generator's settings."""
    return {"format": FORMAT, "task": task_key(task), "generator": digest(generator_settings(preset, scenes))}


def ambiguity_inputs(task: Task, preset: Preset) -> dict:
    """What the ambiguity report is made from: the task (its calibrated settings among its fields)
    and the number of random scenes it compares the definitions on."""
    return {"format": FORMAT, "task": task_key(task), "scenes": preset.evaluation.ambiguity_scenes}
