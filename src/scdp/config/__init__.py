"""Typed, validated configuration: one dataclass per section, and the preset that holds them.

A preset is built from sections, each a frozen dataclass that checks the type and range of
every field on construction and round-trips through JSON (``to_dict`` / ``from_dict``),
which is how checkpoints and ``results.json`` record them::

    Preset
    ├── data        DataConfig        demonstrations, style subsets, encoder scenes
    ├── base        BaseSection       model: DiffusionConfig, train: TrainConfig
    ├── encoder     EncoderSection    model: EncoderConfig,   train: TrainConfig
    ├── style       StyleSection      model: StyleConfig,     train: TrainConfig
    ├── paper_style StyleSection      the paper's design, for method scdp_paper
    ├── ld          LDSection         guidance: GuidanceConfig, train: TrainConfig
    ├── student     StudentSection    the few-step student's steps, teacher and schedule
    ├── evaluation  EvaluationConfig  scene counts and seeds
    └── layouts     LayoutsConfig     the authors' per-layout protocol

Planning is configured apart from the preset (:mod:`scdp.config.planning`): a
:class:`PlannerSpec` names the planner, :class:`PlanningOptions` holds the planning-time options
(sampler, steps, warm start, device, runtime and the profile that fills what is left unset) that
change nothing that was trained.

Dimensions that come from the task or from another part (``state_dim``, ``goal_dim``,
``context_dim``, ``bottleneck_dim``) are ``None`` in a preset and filled in when a part is
built. Any field can be overridden with ``section.field=value`` strings
(``Preset.with_overrides``, the CLI's ``--set``); the overrides are recorded with the preset.

The named presets are in :mod:`scdp.presets`.
"""

from scdp.config.planning import PlannerSpec, PlanningOptions
from scdp.config.preset import (
                                SECTIONS,
                                BaseSection,
                                DataConfig,
                                EncoderSection,
                                EvaluationConfig,
                                LayoutsConfig,
                                LDSection,
                                Preset,
                                StudentSection,
                                StyleSection,
                                TrainConfig,
)
from scdp.config.shapes import DiffusionConfig, EncoderConfig, GuidanceConfig, StyleConfig, first_step_of_window

__all__ = ["SECTIONS", "BaseSection", "DataConfig", "DiffusionConfig", "EncoderConfig", "EncoderSection", "EvaluationConfig",
           "GuidanceConfig", "LDSection", "LayoutsConfig", "PlannerSpec", "PlanningOptions", "Preset", "StudentSection",
           "StyleConfig", "StyleSection", "TrainConfig", "first_step_of_window"]
