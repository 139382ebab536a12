"""Training schedules, the preset's sections and the preset itself (see :mod:`scdp.config`)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace

from scdp import planners
from scdp.config.shapes import DiffusionConfig, EncoderConfig, GuidanceConfig, StyleConfig
from scdp.errors import ScdpError
from scdp.keys import (
    ARBITRATIONS,
    EFFICIENT_SCORES,
    LAYOUT_IDS,
    LEGIBLE_SCORES,
    MAX_GOALS,
    MIN_GOALS,
    PAPER_METHOD,
    STUDENT_PART,
    STYLE_WINDOWS,
    TURN_FROM,
    is_style_part,
    part_design,
)
from scdp.sections import Section, assign

# -- schedules and sections -------------------------------------------------------------------


@dataclass(frozen=True)
class TrainConfig(Section):
    """One schedule for the shared training loop."""

    epochs: int
    batch_size: int
    lr: float
    weight_decay: float = 1e-6
    warmup_steps: int = 500
    ema_power: float | None = 0.75  # None: no EMA
    checkpoint_every: int = 200  # optimiser steps between resumable checkpoints
    seed: int = 0  # weight initialisation, shuffling, noise
    min_steps: int = 0  # train at least this many steps, whatever the dataset size

    _positive = ("epochs", "batch_size", "lr", "checkpoint_every")

    def _check(self):
        for name in ("weight_decay", "warmup_steps", "seed", "min_steps"):
            if getattr(self, name) < 0:
                raise ScdpError(name, f"must be >= 0, got {getattr(self, name)}")
        if self.ema_power is not None and not 0.0 < self.ema_power <= 1.0:
            raise ScdpError("ema_power", f"must lie in (0, 1] (or be null for no EMA), got {self.ema_power}")


@dataclass(frozen=True)
class DataConfig(Section):
    """Demonstrations of the random-scene protocol, the style subsets and the encoder's scenes."""

    num_demos: int = 200
    base_demos: int | None = None  # the base and LD train on the first this many demos (None or more: all); styles use all
    seed: int = 0
    style_fraction: float = 0.2  # top share of demos by d_hat (legible) or e_hat (efficient)
    encoder_scenes: int = 5000  # random scenes the scene autoencoder learns from
    goals: int = 2  # goals per random scene (g* and goals - 1 distractors), in demos, encoder and evaluation
    turning: float = 0.0  # share of demos that change course part-way (scdp.data.bezier.turning_path)
    turn_from: str = "start"  # where their second course starts: "start" (another curve from it) or "point" (the turn)

    _positive = ("num_demos", "encoder_scenes")

    def _check(self):
        if isinstance(self.goals, bool) or not isinstance(self.goals, int) or not MIN_GOALS <= self.goals <= MAX_GOALS:
            raise ScdpError("goals", f"a scene holds {MIN_GOALS}..{MAX_GOALS} goals (the target and 1..{MAX_GOALS - 1} "
                                     f"distractors), got {self.goals!r}")
        if self.seed < 0:
            raise ScdpError("seed", f"must be >= 0, got {self.seed}")
        if not 0.0 < self.style_fraction <= 1.0:
            raise ScdpError("style_fraction", f"must lie in (0, 1], got {self.style_fraction}")
        if not 0.0 <= self.turning <= 1.0:
            raise ScdpError("turning", f"a share of demos from 0 to 1, got {self.turning}")
        if self.turn_from not in TURN_FROM:
            raise ScdpError("turn_from", f"one of {', '.join(TURN_FROM)}, got {self.turn_from!r}")
        if self.base_demos is not None and self.base_demos <= 0:
            raise ScdpError("base_demos", f"must be > 0 (or null: every demo), got {self.base_demos}")


@dataclass(frozen=True)
class BaseSection(Section):
    """The frozen base Diffusion Policy (DP, and SCDP's backbone)."""

    model: DiffusionConfig = field(default_factory=DiffusionConfig)
    train: TrainConfig = field(default_factory=lambda: TrainConfig(epochs=100, batch_size=256, lr=1e-4))


@dataclass(frozen=True)
class EncoderSection(Section):
    model: EncoderConfig = field(default_factory=EncoderConfig)
    train: TrainConfig = field(default_factory=lambda: TrainConfig(epochs=50, batch_size=64, lr=1e-5, warmup_steps=0, ema_power=None))


@dataclass(frozen=True)
class StyleSection(Section):
    """The two style predictors. ``early_windows`` < 1 trains them only on the windows in that
    first fraction of each episode, where the side a path takes is still open. ``arbitration``
    is how SCDP's auto mode picks a chunk's style (the paper's ``ellipse``, or eq. 3 itself,
    ``probabilistic``); it is saved with the predictors and used when they plan.
    ``x0_weight_cap`` > 1 weights each window's ε-MSE by ``clip(1 / SNR_k, 1, cap)``, so that
    the noisy steps where a path's side is decided count (1: the paper's plain ε-MSE; see
    :meth:`scdp.policies.diffusion.DiffusionPolicy.loss`). ``efficient_score`` ranks the demos
    of the efficient predictor's subset: ``e_hat`` (the paper: the straightest) or
    ``transparency`` (T of eq. 7: efficient where goals are far apart, detached where close).
    ``legible_score`` ranks the legible predictor's: ``d_hat`` (the paper: the most detached),
    ``legibility`` (Dragan's legibility, what the path-length observer reads, normalised over the
    scene's reference paths) or ``viewpoint_legibility`` (the same as the task's viewer sees the
    motion; :func:`scdp.scoring.subsets.observer_legibility`). ``windows`` says which windows they
    learn from: every window of those top demos (``demos``), or, with ``rest``, the windows of any
    demo whose remaining path is among the most legible (efficient) of its tenth of the motion,
    the label of a style chosen part-way (:mod:`scdp.scoring.rest`; the scores above then go unused)."""

    model: StyleConfig = field(default_factory=StyleConfig)
    train: TrainConfig = field(default_factory=lambda: TrainConfig(epochs=300, batch_size=128, lr=1e-5, warmup_steps=0, ema_power=None))
    early_windows: float = 1.0
    arbitration: str = "ellipse"
    x0_weight_cap: float = 1.0
    efficient_score: str = "e_hat"
    legible_score: str = "d_hat"
    windows: str = "demos"

    def _check(self):
        if self.legible_score not in LEGIBLE_SCORES:
            raise ScdpError("legible_score", f"one of {', '.join(LEGIBLE_SCORES)}, got {self.legible_score!r}")
        if self.efficient_score not in EFFICIENT_SCORES:
            raise ScdpError("efficient_score", f"one of {', '.join(EFFICIENT_SCORES)}, got {self.efficient_score!r}")
        if not 0.0 < self.early_windows <= 1.0:
            raise ScdpError("early_windows", f"must lie in (0, 1], got {self.early_windows}")
        if not self.x0_weight_cap >= 1.0:
            raise ScdpError("x0_weight_cap", f"must be >= 1 (1: plain ε-MSE), got {self.x0_weight_cap}")
        if self.arbitration not in ARBITRATIONS:
            raise ScdpError("arbitration", f"one of {', '.join(ARBITRATIONS)}, got {self.arbitration!r}")
        if self.windows not in STYLE_WINDOWS:
            raise ScdpError("windows", f"one of {', '.join(STYLE_WINDOWS)}, got {self.windows!r}")


@dataclass(frozen=True)
class LDSection(Section):
    """Legibility Diffuser: its guidance and its goal-dropout base's schedule (``None``: the base's).

    ``init`` is where that base starts: ``scratch`` (fresh weights, the authors' way) or ``base``
    (the trained DP base, fine-tuned with goal dropout for ``train``'s steps), so that LD plans
    from a net that reaches its goals unguided as well as DP's does."""

    guidance: GuidanceConfig = field(default_factory=GuidanceConfig)
    train: TrainConfig | None = None
    init: str = "scratch"

    def _check(self):
        if self.init not in ("scratch", "base"):
            raise ScdpError("init", f"must be 'scratch' or 'base', got {self.init!r}")


@dataclass(frozen=True)
class StudentSection(Section):
    """The few-step student of methods ``dp_student`` and ``scdp_student`` (:mod:`scdp.training.distill`):
    the base fine-tuned so that DDIM at ``steps`` steps (its network calls per chunk) reaches the chunk
    the frozen base reaches with DDIM at ``teacher_steps``, from the same noise and with the same style
    film; a share ``styled`` of the windows is distilled with a predictor's film, the rest with none.
    ``step_weight`` weighs the match of the chunk's steps against that of its points."""

    steps: int = 2
    teacher_steps: int = 20
    styled: float = 0.75
    step_weight: float = 0.0  # off: why, in scdp.training.distill
    # one pass over the cpu preset's windows (about 860 steps; each runs the teacher 20 times): minutes per task
    train: TrainConfig = field(default_factory=lambda: TrainConfig(epochs=1, batch_size=128, lr=1e-4, warmup_steps=50,
                                                                   ema_power=None))

    _positive = ("steps", "teacher_steps")

    def _check(self):
        if self.steps >= self.teacher_steps:
            raise ScdpError("steps", f"a student takes fewer steps than its teacher ({self.teacher_steps}), got {self.steps}")
        if not 0.0 <= self.styled <= 1.0:
            raise ScdpError("styled", f"a share of windows from 0 to 1, got {self.styled}")
        if self.step_weight < 0:
            raise ScdpError("step_weight", f"must be >= 0, got {self.step_weight}")


@dataclass(frozen=True)
class EvaluationConfig(Section):
    """What ``scdp reproduce`` evaluates: planners by name (:func:`scdp.planners.names`; the
    Dataset row is always added), scene counts and seeds."""

    methods: tuple[str, ...] = ("dp", "ld", "scdp")
    scenes: int = 100  # per random scene set (ambiguous / non-ambiguous)
    layout_repeats: int = 5  # rollouts per layout and target
    seed: int = 1
    ambiguity_scenes: int = 10_000  # random scenes of the ambiguity calibration report

    _positive = ("scenes", "layout_repeats", "ambiguity_scenes")

    def _check(self):
        if self.seed < 0:
            raise ScdpError("seed", f"must be >= 0, got {self.seed}")
        unknown = [m for m in self.methods if m not in planners.names()]
        if unknown or len(set(self.methods)) != len(self.methods):
            raise ScdpError("methods", f"unknown or repeated planners {unknown or list(self.methods)} "
                                       f"(choose from {', '.join(planners.names())})")
        missing = [m for m in ("dp", "ld", "scdp") if m not in self.methods]
        if missing:  # the report's tables and claims compare the paper's three methods
            raise ScdpError("methods", f"must include dp, ld and scdp (the paper's tables and claims compare them); "
                                       f"{', '.join(missing)} missing")


@dataclass(frozen=True)
class LayoutsConfig(Section):
    """The authors' per-layout protocol: one model set per layout, trained on ``demos`` demos
    of that layout only, with these schedules (``None``: the random-scene ones)."""

    demos: int = 100
    base_train: TrainConfig | None = None
    style_train: TrainConfig | None = None

    _positive = ("demos",)


SECTIONS = ("data", "base", "encoder", "style", "paper_style", "ld", "student", "evaluation", "layouts")


@dataclass(frozen=True)
class Preset(Section):
    """Everything ``scdp reproduce`` needs, by name, in sections (see the module docstring)."""

    name: str
    data: DataConfig = field(default_factory=DataConfig)
    base: BaseSection = field(default_factory=BaseSection)
    encoder: EncoderSection = field(default_factory=EncoderSection)
    style: StyleSection = field(default_factory=StyleSection)
    # method ``scdp_paper``: the paper's design (bottleneck film at every step, the ellipse, the
    # paper's subsets and every window), trained on the same frozen base as ``style``
    paper_style: StyleSection = field(default_factory=StyleSection)
    ld: LDSection = field(default_factory=LDSection)
    student: StudentSection = field(default_factory=StudentSection)  # trained only when a *_student method is evaluated
    evaluation: EvaluationConfig = field(default_factory=EvaluationConfig)
    layouts: LayoutsConfig = field(default_factory=LayoutsConfig)
    overrides: tuple[str, ...] | None = None  # the ``section.field=value`` strings applied to the named preset

    def _check(self):
        if self.encoder.model.n_goals != EncoderConfig.n_goals:  # one source for the goal count
            raise ScdpError("encoder.model.n_goals",
                            f"follows data.goals (goals per scene); set data.goals={self.encoder.model.n_goals} instead")

    @property
    def encoder_model(self) -> EncoderConfig:
        """The scene encoder's shape, sized for ``data.goals`` goals per scene."""
        return replace(self.encoder.model, n_goals=self.data.goals)

    def schedule(self, part: str) -> TrainConfig:
        """The training schedule of a part: base, ld, encoder, style_legible, style_efficient or student."""
        if part == "base":
            return self.base.train
        if part == "ld":
            return self.ld.train or self.base.train
        if part == "encoder":
            return self.encoder.train
        if part == STUDENT_PART:
            return self.student.train
        if is_style_part(part):
            return self.style_section(part).train
        raise ScdpError("part", f"unknown part {part!r}")

    def style_section(self, part: str) -> StyleSection:
        """The section a style part trains from: ``paper_style`` for the paper design's parts
        (:func:`scdp.keys.part_design`), else ``style``."""
        return self.paper_style if part_design(part) == PAPER_METHOD else self.style

    def for_layout(self, k: int) -> Preset:
        """The preset one per-layout model set trains with: ``layouts.demos`` demos of layout ``k``
        (seeded ``data.seed + k``) and the per-layout schedules."""
        if k not in LAYOUT_IDS:
            raise ScdpError("layout", f"must be {LAYOUT_IDS[0]}..{LAYOUT_IDS[-1]}, got {k}")
        lay = self.layouts
        return replace(self, data=replace(self.data, num_demos=lay.demos, base_demos=None, seed=self.data.seed + k),
                       base=replace(self.base, train=lay.base_train or self.base.train),
                       ld=replace(self.ld, train=lay.base_train or self.ld.train),
                       style=replace(self.style, train=lay.style_train or self.style.train),
                       paper_style=replace(self.paper_style, train=lay.style_train or self.paper_style.train))

    def with_training_seed(self, seed: int) -> Preset:
        """Every part's schedule seeded with ``seed`` (weight initialisation, shuffling, noise),
        recorded as overrides; ``seed = 0`` is the preset as it is."""
        if seed == 0:
            return self
        paths = ["base.train", "encoder.train", "style.train", "paper_style.train"] + ["ld.train"] * (self.ld.train is not None)
        paths += [f"layouts.{k}" for k in ("base_train", "style_train") if getattr(self.layouts, k) is not None]
        return self.with_overrides([f"{p}.seed={seed}" for p in paths])

    def with_overrides(self, assignments) -> Preset:
        """Apply ``section.field=value`` (or ``section.sub.field=value``) strings; values are JSON
        (numbers, true/false, null, [lists]) or bare strings. Refuses unknown paths and bad values."""
        preset = self
        for text in assignments:
            path, sep, raw = str(text).partition("=")
            if not sep or not path:
                raise ScdpError("--set", f"expected section.field=value, got {text!r}")
            try:
                value = json.loads(raw)
            except ValueError:
                value = raw
            preset = assign(preset, path.split("."), value, path)
        return replace(preset, overrides=tuple(self.overrides or ()) + tuple(str(a) for a in assignments)) if assignments else preset
