"""Typed, validated configuration: model shapes, training schedules and the named presets.

Every config is a frozen dataclass that checks itself on construction and round-trips
through JSON (``asdict`` / ``from_dict``), which is how checkpoints record them.

Presets:

* ``paper``: the authors' sizes (U-Net [256, 512, 1024], ~65 M parameters; 100 epochs at
  batch 256; DDPM with 100 steps; encoder 50 epochs; predictors 300 epochs).
* ``cpu``: a 1.1 M-parameter U-Net and short schedules so that the whole reproduction runs
  on 2 CPU cores in well under 45 minutes. Sampling is the paper's DDPM with 100 steps
  (DDIM with 10 steps made the small Block Reach policy jitter and fail half its reaches).
  Its per-configuration model sets train for 500 steps (predictors 15 epochs), which is
  enough for Navigation but leaves Block Reach undertrained (``results/cpu/ANALYSIS.md``).
* ``tiny``: seconds-long smoke runs for the tests.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, replace

from scdp.errors import ScdpError


class _Config:
    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict):
        names = {f.name for f in fields(cls)}
        unknown = set(data) - names
        if unknown:
            raise ScdpError("config", f"unknown {cls.__name__} fields {sorted(unknown)}")
        kwargs = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
        return cls(**kwargs)


def _positive(name: str, value) -> None:
    if not value > 0:
        raise ScdpError(name, f"must be > 0, got {value}")


@dataclass(frozen=True)
class DiffusionConfig(_Config):
    """The goal-conditioned Diffusion Policy. Observation: [state, g*] over ``n_obs_steps``."""

    state_dim: int
    goal_dim: int
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
    sampler: str = "ddpm"  # or "ddim"
    num_inference_steps: int = 100
    p_uncond: float = 0.0  # goal dropout (Legibility Diffuser's base uses 0.1)
    relative_actions: bool = True  # predict next states relative to the current state
    goal_offset: bool = True  # also observe g* - p(s), the target seen from the robot (task space)


    def __post_init__(self):
        for name in ("state_dim", "goal_dim", "n_obs_steps", "horizon", "n_action_steps", "num_train_timesteps", "num_inference_steps"):
            _positive(name, getattr(self, name))
        factor = 2 ** (len(self.down_dims) - 1)
        if self.horizon % factor:
            raise ScdpError("horizon", f"must be a multiple of {factor} for {len(self.down_dims)} U-Net levels, got {self.horizon}")
        if self.n_obs_steps - 1 + self.n_action_steps > self.horizon:
            raise ScdpError("n_action_steps", "observation and action steps do not fit in the horizon")
        if any(d % self.n_groups for d in self.down_dims):
            raise ScdpError("down_dims", f"every width must be divisible by n_groups={self.n_groups}")
        if self.sampler not in ("ddpm", "ddim"):
            raise ScdpError("sampler", f"ddpm or ddim, got {self.sampler!r}")
        if self.num_inference_steps > self.num_train_timesteps:
            raise ScdpError("num_inference_steps", "cannot exceed num_train_timesteps")
        if not 0.0 <= self.p_uncond < 1.0:
            raise ScdpError("p_uncond", f"must lie in [0, 1), got {self.p_uncond}")

    @property
    def global_cond_dim(self) -> int:
        return self.n_obs_steps * (self.state_dim + self.goal_dim * (2 if self.goal_offset else 1))


@dataclass(frozen=True)
class EncoderConfig(_Config):
    """Scene autoencoder over the enriched goal vectors [g, r, j] (g* first)."""

    goal_dim: int
    n_goals: int = 2
    hidden: tuple[int, ...] = (128, 128)
    context_dim: int = 64

    def __post_init__(self):
        _positive("goal_dim", self.goal_dim)
        if self.n_goals < 2:
            raise ScdpError("n_goals", f"a scene needs a target and at least one distractor, got {self.n_goals}")
        _positive("context_dim", self.context_dim)

    @property
    def input_dim(self) -> int:
        return self.n_goals * (2 * self.goal_dim + 1)


@dataclass(frozen=True)
class StyleConfig(_Config):
    """Style predictor: context c -> (γ, β) for the U-Net bottleneck."""

    context_dim: int
    bottleneck_dim: int
    hidden: int = 384
    layers: int = 4  # linear layers including the (γ, β) head

    def __post_init__(self):
        for name in ("context_dim", "bottleneck_dim", "hidden"):
            _positive(name, getattr(self, name))
        if self.layers < 2:
            raise ScdpError("layers", f"need at least 2, got {self.layers}")


@dataclass(frozen=True)
class TrainConfig(_Config):
    """One schedule for the shared training loop."""

    epochs: int
    batch_size: int
    lr: float
    weight_decay: float = 1e-6
    warmup_steps: int = 500
    ema_power: float | None = 0.75  # None: no EMA
    checkpoint_every: int = 200  # optimiser steps between resumable checkpoints
    seed: int = 0
    min_steps: int = 0  # train at least this many steps, whatever the dataset size

    def __post_init__(self):
        for name in ("epochs", "batch_size", "lr", "checkpoint_every"):
            _positive(name, getattr(self, name))


@dataclass(frozen=True)
class Preset(_Config):
    """Everything ``scdp reproduce`` needs, by name."""

    name: str
    num_demos: int = 200
    demo_seed: int = 0
    down_dims: tuple[int, ...] = (256, 512, 1024)
    step_embed_dim: int = 256
    sampler: str = "ddpm"
    num_inference_steps: int = 100
    encoder_scenes: int = 5000
    style_hidden: int = 384
    base: TrainConfig = field(default_factory=lambda: TrainConfig(epochs=100, batch_size=256, lr=1e-4))
    encoder: TrainConfig = field(default_factory=lambda: TrainConfig(epochs=50, batch_size=64, lr=1e-5, warmup_steps=0, ema_power=None))
    style: TrainConfig = field(default_factory=lambda: TrainConfig(epochs=300, batch_size=128, lr=1e-5, warmup_steps=0, ema_power=None))
    style_fraction: float = 0.2
    eval_scenes: int = 100  # per scene set (ambiguous / non-ambiguous)
    config_repeats: int = 5  # rollouts per fixed configuration and target
    eval_seed: int = 1
    ambiguity_scenes: int = 10_000
    # The authors' per-configuration protocol (``reproduce --protocol per_config``): one model
    # set per fixed configuration, trained on ``config_demos`` demos of that configuration only.
    config_demos: int = 100
    config_base: TrainConfig | None = None  # schedule of its base and LD base; None: ``base``
    config_style: TrainConfig | None = None  # schedule of its style predictors; None: ``style``

    def __post_init__(self):
        for name in ("num_demos", "num_inference_steps", "encoder_scenes", "style_hidden", "eval_scenes",
                     "config_repeats", "ambiguity_scenes", "config_demos"):
            _positive(name, getattr(self, name))
        if not 0.0 < self.style_fraction <= 1.0:
            raise ScdpError("style_fraction", f"must lie in (0, 1], got {self.style_fraction}")

    def for_config(self, k: int) -> "Preset":
        """The preset one per-configuration model set trains with: ``config_demos`` demos of
        configuration ``k`` (seeded ``demo_seed + k``) and the per-configuration schedules."""
        if k not in range(1, 7):
            raise ScdpError("config", f"must be 1..6, got {k}")
        return replace(self, num_demos=self.config_demos, demo_seed=self.demo_seed + k,
                       base=self.config_base or self.base, style=self.config_style or self.style)

    def diffusion(self, task, p_uncond: float = 0.0) -> DiffusionConfig:
        return DiffusionConfig(state_dim=task.state_dim, goal_dim=task.space_dim, down_dims=self.down_dims,
                               step_embed_dim=self.step_embed_dim, sampler=self.sampler,
                               num_inference_steps=self.num_inference_steps, p_uncond=p_uncond)

    @classmethod
    def from_dict(cls, data: dict):
        data = dict(data)
        for key in ("base", "encoder", "style", "config_base", "config_style"):
            if isinstance(data.get(key), dict):
                data[key] = TrainConfig.from_dict(data[key])
        return super().from_dict(data)


PRESETS = {
    "paper": Preset("paper"),
    "cpu": Preset(
        "cpu", down_dims=(32, 64, 128), step_embed_dim=64,
        style_hidden=256,
        # 1680 steps = 20 Navigation epochs; Block Reach demos are shorter, so it gets ~40 epochs
        base=TrainConfig(epochs=20, batch_size=256, lr=1e-3, warmup_steps=100, min_steps=1680),
        encoder=TrainConfig(epochs=50, batch_size=64, lr=1e-3, warmup_steps=0, ema_power=None),
        style=TrainConfig(epochs=30, batch_size=128, lr=1e-3, warmup_steps=20, ema_power=None),
        # per configuration: 100 demos of one goal pair, a narrower job; 12 model sets must fit
        # in about an hour on 2 cores (results/cpu/report.md records the stage times)
        config_base=TrainConfig(epochs=10, batch_size=256, lr=1e-3, warmup_steps=50, min_steps=500),
        config_style=TrainConfig(epochs=15, batch_size=128, lr=1e-3, warmup_steps=20, ema_power=None),
    ),
    "tiny": Preset(
        "tiny", num_demos=8, down_dims=(8, 16, 32), step_embed_dim=16, sampler="ddim", num_inference_steps=4,
        encoder_scenes=200, style_hidden=16, style_fraction=0.5, eval_scenes=2, config_repeats=1, ambiguity_scenes=500,
        base=TrainConfig(epochs=1, batch_size=64, lr=1e-3, warmup_steps=2, checkpoint_every=5),
        encoder=TrainConfig(epochs=2, batch_size=64, lr=1e-3, warmup_steps=0, ema_power=None),
        style=TrainConfig(epochs=1, batch_size=64, lr=1e-3, warmup_steps=0, ema_power=None),
        config_demos=4,
    ),
}


def get_preset(name) -> Preset:
    try:
        return PRESETS[name]
    except (KeyError, TypeError):
        raise ScdpError("--preset", f"unknown preset {name!r} (choose from {', '.join(PRESETS)})") from None
