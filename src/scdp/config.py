"""Typed, validated configuration: one dataclass per section, and the preset that holds them.

A preset is built from sections, each a frozen dataclass that checks the type and range of
every field on construction and round-trips through JSON (``to_dict`` / ``from_dict``),
which is how checkpoints and ``results.json`` record them::

    Preset
    ├── data        DataConfig        demonstrations, style subsets, encoder scenes
    ├── base        BaseSection       model: DiffusionConfig, train: TrainConfig
    ├── encoder     EncoderSection    model: EncoderConfig,   train: TrainConfig
    ├── style       StyleSection      model: StyleConfig,     train: TrainConfig
    ├── ld          LDSection         guidance: GuidanceConfig, train: TrainConfig
    ├── evaluation  EvaluationConfig  scene counts and seeds
    └── layouts     LayoutsConfig     the authors' per-layout protocol

Dimensions that come from the task or from another part (``state_dim``, ``goal_dim``,
``context_dim``, ``bottleneck_dim``) are ``None`` in a preset and filled in when a part is
built. Any field can be overridden with ``section.field=value`` strings
(``Preset.with_overrides``, the CLI's ``--set``); the overrides are recorded with the preset.

The named presets are in :mod:`scdp.presets`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace

from scdp.errors import ScdpError
from scdp.keys import ALL_PLANNERS, ARBITRATIONS, EFFICIENT_SCORES, LAYOUT_IDS, SAMPLERS
from scdp.sections import Section, assign


# -- model shapes --------------------------------------------------------------------------------


@dataclass(frozen=True)
class DiffusionConfig(Section):
    """The goal-conditioned Diffusion Policy. Observation: [state, g*(, g* - p(s))] over ``n_obs_steps``.

    ``state_dim`` and ``goal_dim`` come from the task (``None`` in a preset).
    """

    state_dim: int | None = None
    goal_dim: int | None = None
    n_obs_steps: int = 2
    horizon: int = 16
    n_action_steps: int = 8
    down_dims: tuple[int, ...] = (256, 512, 1024)
    step_embed_dim: int = 256
    kernel_size: int = 5
    n_groups: int = 8
    num_train_timesteps: int = 100
    beta_schedule: str = "squaredcos_cap_v2"
    clip_sample: bool = True
    sampler: str = "ddpm"  # planning-time scheduler: ddpm (the paper), ddim or dpmsolver (DPM-Solver++)
    num_inference_steps: int = 100
    p_uncond: float = 0.0  # goal dropout (Legibility Diffuser's base: LDSection.guidance.p_uncond)
    relative_actions: bool = True  # predict next states relative to the current state
    goal_offset: bool = True  # also observe g* - p(s), the target seen from the robot (task space)

    _positive = ("state_dim", "goal_dim", "n_obs_steps", "horizon", "n_action_steps", "step_embed_dim", "kernel_size",
                 "n_groups", "num_train_timesteps", "num_inference_steps")

    def _check(self):
        if any(d <= 0 for d in self.down_dims):
            raise ScdpError("down_dims", f"widths must be > 0, got {self.down_dims}")
        factor = 2 ** (len(self.down_dims) - 1)
        if self.horizon % factor:
            raise ScdpError("horizon", f"must be a multiple of {factor} for {len(self.down_dims)} U-Net levels, got {self.horizon}")
        if self.n_obs_steps - 1 + self.n_action_steps > self.horizon:
            raise ScdpError("n_action_steps", "observation and action steps do not fit in the horizon")
        if any(d % self.n_groups for d in self.down_dims):
            raise ScdpError("down_dims", f"every width must be divisible by n_groups={self.n_groups}")
        if self.sampler not in SAMPLERS:
            raise ScdpError("sampler", f"one of {', '.join(SAMPLERS)}, got {self.sampler!r}")
        if self.num_inference_steps > self.num_train_timesteps:
            raise ScdpError("num_inference_steps", "cannot exceed num_train_timesteps")
        if not 0.0 <= self.p_uncond < 1.0:
            raise ScdpError("p_uncond", f"must lie in [0, 1), got {self.p_uncond}")

    def for_task(self, task, p_uncond: float | None = None) -> DiffusionConfig:
        """This shape with the task's dimensions (and, for LD's base, its goal dropout)."""
        return replace(self, state_dim=task.state_dim, goal_dim=task.space_dim,
                       p_uncond=self.p_uncond if p_uncond is None else p_uncond)

    @property
    def global_cond_dim(self) -> int:
        return self.n_obs_steps * (self.state_dim + self.goal_dim * (2 if self.goal_offset else 1))


@dataclass(frozen=True)
class EncoderConfig(Section):
    """Scene autoencoder over the enriched goal vectors [g, r, j] (g* first)."""

    goal_dim: int | None = None
    n_goals: int = 2
    hidden: tuple[int, ...] = (128, 128)
    context_dim: int = 64

    _positive = ("goal_dim", "context_dim")

    def _check(self):
        if self.n_goals < 2:
            raise ScdpError("n_goals", f"a scene needs a target and at least one distractor, got {self.n_goals}")
        if any(h <= 0 for h in self.hidden):
            raise ScdpError("hidden", f"widths must be > 0, got {self.hidden}")

    def for_task(self, task, n_goals: int | None = None) -> EncoderConfig:
        return replace(self, goal_dim=task.space_dim, n_goals=n_goals or self.n_goals)

    @property
    def input_dim(self) -> int:
        return self.n_goals * (2 * self.goal_dim + 1)


@dataclass(frozen=True)
class StyleConfig(Section):
    """Style predictor: context c -> FiLM (γ, β) for the U-Net bottleneck (or every block)."""

    context_dim: int | None = None
    bottleneck_dim: int | None = None
    hidden: int = 384
    layers: int = 4  # linear layers including the (γ, β) head
    scene_frame: bool = False  # also read the distractors in the robot -> g* frame (not in the paper)
    frame_dim: int = 0  # size of that input, set by ``for_parts``
    film_blocks: str = "bottleneck"  # where the film acts: the paper's bottleneck, or "all" residual blocks
    film_dim: int | None = None  # width of γ (and β), set by ``for_parts``; None: the bottleneck's
    # the film acts on the noisiest ``noise_window`` of the diffusion steps only (k >= (1 - window) K),
    # where a sample's coarse shape is decided; the base alone refines below. 1: every step (the paper)
    noise_window: float = 1.0

    _positive = ("context_dim", "bottleneck_dim", "hidden", "film_dim")

    def _check(self):
        if self.layers < 2:
            raise ScdpError("layers", f"need at least 2, got {self.layers}")
        if self.frame_dim < 0:
            raise ScdpError("frame_dim", f"must be >= 0, got {self.frame_dim}")
        if self.film_blocks not in ("bottleneck", "all"):
            raise ScdpError("film_blocks", f"must be 'bottleneck' or 'all', got {self.film_blocks!r}")
        if not 0.0 < self.noise_window <= 1.0:
            raise ScdpError("noise_window", f"must lie in (0, 1], got {self.noise_window}")

    def first_styled_step(self, num_train_timesteps: int) -> int:
        """The lowest diffusion step k at which the film acts (0 when it acts at every step)."""
        return int(round((1.0 - self.noise_window) * num_train_timesteps))

    @property
    def film_width(self) -> int | None:
        return self.film_dim or self.bottleneck_dim

    def for_parts(self, context_dim: int, bottleneck_dim: int, n_goals: int = 2, goal_dim: int = 2,
                  film_dim: int | None = None) -> StyleConfig:
        frame = (n_goals - 1) * (3 if goal_dim == 3 else 2) if self.scene_frame else 0
        return replace(self, context_dim=context_dim, bottleneck_dim=bottleneck_dim, frame_dim=frame,
                       film_dim=film_dim or bottleneck_dim)


@dataclass(frozen=True)
class GuidanceConfig(Section):
    """Legibility Diffuser: ε̃ = (1 + w) ε(g*) − α w ε(g⁻) − (1 − α) w ε(∅); ``w ← decay · w`` per chunk.

    ``p_uncond`` is the goal dropout its base is trained with (the null goal is all zeros).
    """

    w0: float = 4.5
    alpha: float = 0.9
    decay: float = 0.5
    p_uncond: float = 0.1

    def _check(self):
        if self.w0 < 0:
            raise ScdpError("w0", f"must be >= 0, got {self.w0}")
        if not 0.0 <= self.alpha <= 1.0:
            raise ScdpError("alpha", f"must lie in [0, 1], got {self.alpha}")
        if not 0.0 < self.decay <= 1.0:
            raise ScdpError("decay", f"must lie in (0, 1], got {self.decay}")
        if not 0.0 < self.p_uncond < 1.0:
            raise ScdpError("p_uncond", f"must lie in (0, 1), got {self.p_uncond}")


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

    _positive = ("num_demos", "encoder_scenes")

    def _check(self):
        if self.seed < 0:
            raise ScdpError("seed", f"must be >= 0, got {self.seed}")
        if not 0.0 < self.style_fraction <= 1.0:
            raise ScdpError("style_fraction", f"must lie in (0, 1], got {self.style_fraction}")
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
    ``transparency`` (T of eq. 7: efficient where goals are far apart, detached where close)."""

    model: StyleConfig = field(default_factory=StyleConfig)
    train: TrainConfig = field(default_factory=lambda: TrainConfig(epochs=300, batch_size=128, lr=1e-5, warmup_steps=0, ema_power=None))
    early_windows: float = 1.0
    arbitration: str = "ellipse"
    x0_weight_cap: float = 1.0
    efficient_score: str = "e_hat"

    def _check(self):
        if self.efficient_score not in EFFICIENT_SCORES:
            raise ScdpError("efficient_score", f"one of {', '.join(EFFICIENT_SCORES)}, got {self.efficient_score!r}")
        if not 0.0 < self.early_windows <= 1.0:
            raise ScdpError("early_windows", f"must lie in (0, 1], got {self.early_windows}")
        if not self.x0_weight_cap >= 1.0:
            raise ScdpError("x0_weight_cap", f"must be >= 1 (1: plain ε-MSE), got {self.x0_weight_cap}")
        if self.arbitration not in ARBITRATIONS:
            raise ScdpError("arbitration", f"one of {', '.join(ARBITRATIONS)}, got {self.arbitration!r}")


@dataclass(frozen=True)
class LDSection(Section):
    """Legibility Diffuser: its guidance and its goal-dropout base's schedule (``None``: the base's)."""

    guidance: GuidanceConfig = field(default_factory=GuidanceConfig)
    train: TrainConfig | None = None


@dataclass(frozen=True)
class EvaluationConfig(Section):
    """What ``scdp reproduce`` evaluates: planners by name (:data:`scdp.keys.ALL_PLANNERS`; the
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
        unknown = [m for m in self.methods if m not in ALL_PLANNERS]
        if unknown or len(set(self.methods)) != len(self.methods):
            raise ScdpError("methods", f"unknown or repeated planners {unknown or list(self.methods)} (choose from {', '.join(ALL_PLANNERS)})")


@dataclass(frozen=True)
class LayoutsConfig(Section):
    """The authors' per-layout protocol: one model set per layout, trained on ``demos`` demos
    of that layout only, with these schedules (``None``: the random-scene ones)."""

    demos: int = 100
    base_train: TrainConfig | None = None
    style_train: TrainConfig | None = None

    _positive = ("demos",)


SECTIONS = ("data", "base", "encoder", "style", "ld", "evaluation", "layouts")


@dataclass(frozen=True)
class Preset(Section):
    """Everything ``scdp reproduce`` needs, by name, in sections (see the module docstring)."""

    name: str
    data: DataConfig = field(default_factory=DataConfig)
    base: BaseSection = field(default_factory=BaseSection)
    encoder: EncoderSection = field(default_factory=EncoderSection)
    style: StyleSection = field(default_factory=StyleSection)
    ld: LDSection = field(default_factory=LDSection)
    evaluation: EvaluationConfig = field(default_factory=EvaluationConfig)
    layouts: LayoutsConfig = field(default_factory=LayoutsConfig)
    overrides: tuple[str, ...] | None = None  # the ``section.field=value`` strings applied to the named preset

    def schedule(self, part: str) -> TrainConfig:
        """The training schedule of a part: base, ld, encoder, style_legible or style_efficient."""
        if part == "base":
            return self.base.train
        if part == "ld":
            return self.ld.train or self.base.train
        if part == "encoder":
            return self.encoder.train
        if part.startswith("style"):
            return self.style.train
        raise ScdpError("part", f"unknown part {part!r}")

    def recipe(self, part: str) -> dict:
        """What a trained part depends on besides its schedule, as recorded in its checkpoint
        (a checkpoint without a key was trained with that key's default)."""
        return {"score": self.style.efficient_score} if part == "style_efficient" else {}

    def for_layout(self, k: int) -> Preset:
        """The preset one per-layout model set trains with: ``layouts.demos`` demos of layout ``k``
        (seeded ``data.seed + k``) and the per-layout schedules."""
        if k not in LAYOUT_IDS:
            raise ScdpError("layout", f"must be {LAYOUT_IDS[0]}..{LAYOUT_IDS[-1]}, got {k}")
        lay = self.layouts
        return replace(self, data=replace(self.data, num_demos=lay.demos, base_demos=None, seed=self.data.seed + k),
                       base=replace(self.base, train=lay.base_train or self.base.train),
                       ld=replace(self.ld, train=lay.base_train or self.ld.train),
                       style=replace(self.style, train=lay.style_train or self.style.train))

    def with_training_seed(self, seed: int) -> Preset:
        """Every part's schedule seeded with ``seed`` (weight initialisation, shuffling, noise),
        recorded as overrides; ``seed = 0`` is the preset as it is."""
        if seed == 0:
            return self
        paths = ["base.train", "encoder.train", "style.train"] + ["ld.train"] * (self.ld.train is not None)
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
