"""What a trained part depends on: the one answer used by ``train --resume`` and by
``reproduce``'s up-to-date check.

A part's *recipe* is every option of the preset that changes its weights, and nothing else:
its model shape, its schedule, the data options that pick what it learns from, and (for the
parts trained on top of others) which inputs it starts from. Planning-time options (sampler,
step count, LD's guidance weights, SCDP's arbitration), evaluation options and the preset's
name are not in it, so changing them retrains nothing; changing anything in it retrains that
part and, through the input checks, whatever depends on it.

The contents of a part's inputs (demonstrations, base, encoder) are checked apart from the
recipe, by their fingerprints: when resuming, and in ``reproduce``
(:mod:`scdp.pipeline.fingerprints`).
"""

from __future__ import annotations

import json

from scdp import planners
from scdp.config import Preset
from scdp.errors import ScdpError
from scdp.keys import MODEL_PARTS, PAPER_STYLE_PARTS, STUDENT_PART, is_style_part

# Planning-time fields of the base's DiffusionConfig: they do not change a trained net.
PLANNING_FIELDS = ("sampler", "num_inference_steps")


def model_parts(preset: Preset) -> tuple[str, ...]:
    """The parts one model set trains: what the evaluated planners train (:attr:`PlannerKind.trains
    <scdp.planners.PlannerKind.trains>`: base, both predictors, LD's base, and the paper-design
    predictors when ``scdp_paper`` is evaluated), in :data:`~scdp.keys.MODEL_PARTS`' order."""
    wanted = {p for m in preset.evaluation.methods for p in planners.kind(m).trains}
    order = (*MODEL_PARTS, *PAPER_STYLE_PARTS)
    return tuple(p for p in order if p in wanted) + tuple(sorted(wanted - set(order)))


def _net(preset: Preset) -> dict:
    return {k: v for k, v in preset.base.model.to_dict().items() if k not in PLANNING_FIELDS}


def part_recipe(preset: Preset, part: str) -> dict:
    """Everything in ``preset`` that changes ``part``'s weights, as JSON reads it back."""
    data = preset.data
    if part == "encoder":
        recipe = {"model": preset.encoder_model.to_dict(), "train": preset.encoder.train.to_dict(),
                  "scenes": data.encoder_scenes}
    elif part == "base":
        recipe = {"model": _net(preset), "train": preset.base.train.to_dict(), "base_demos": data.base_demos}
    elif part == "ld":
        recipe = {"model": _net(preset), "train": preset.schedule("ld").to_dict(), "base_demos": data.base_demos,
                  "p_uncond": preset.ld.guidance.p_uncond, "init": preset.ld.init}
    elif part == STUDENT_PART:
        student = preset.student.to_dict()
        if not student["step_weight"]:  # off, as before the term existed: older recipes stay current
            del student["step_weight"]
        recipe = {"model": _net(preset), "student": student, "base_demos": data.base_demos}
    elif is_style_part(part):
        section = preset.style_section(part)
        recipe = {"model": section.model.to_dict(), "train": section.train.to_dict(),
                  "early_windows": section.early_windows, "x0_weight_cap": section.x0_weight_cap,
                  "style_fraction": data.style_fraction}
        if part.endswith("_efficient"):
            recipe["score"] = section.efficient_score
        elif section.legible_score != "d_hat":  # the paper's ranking adds nothing: older recipes stay current
            recipe["score"] = section.legible_score
        if section.windows != "demos":  # likewise
            recipe["windows"] = section.windows
    else:
        raise ScdpError("part", f"unknown part {part!r}")
    return json.loads(json.dumps(recipe))


def base_dependent(preset: Preset, part: str) -> bool:
    """Whether ``part`` is trained from the base's weights (the predictors, the student, and LD's base
    when it is fine-tuned from DP's)."""
    return is_style_part(part) or part == STUDENT_PART or (part == "ld" and preset.ld.init == "base")
