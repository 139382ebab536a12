"""The model shapes of a preset: the Diffusion Policy, the scene encoder, the style predictor,
and Legibility Diffuser's guidance (see :mod:`scdp.config`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

from scdp.errors import ScdpError
from scdp.keys import BETA_SCHEDULES, MAX_GOALS, MIN_GOALS, SAMPLERS
from scdp.sections import Section

# -- model shapes --------------------------------------------------------------------------------


def first_step_of_window(window: float, num_train_timesteps: int) -> int:
    """The lowest diffusion step k inside the noisiest ``window`` of the steps (k >= (1 - window) K):
    where SCDP's film (``StyleConfig.noise_window``) and LD's guidance (``GuidanceConfig.window``) act."""
    return int(round((1.0 - window) * num_train_timesteps))


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
        if self.beta_schedule not in BETA_SCHEDULES:
            raise ScdpError("beta_schedule", f"one of {', '.join(BETA_SCHEDULES)}, got {self.beta_schedule!r}")
        if self.sampler not in SAMPLERS:
            raise ScdpError("sampler", f"one of {', '.join(SAMPLERS)}, got {self.sampler!r}")
        if self.num_inference_steps > self.num_train_timesteps:
            raise ScdpError("num_inference_steps", "cannot exceed num_train_timesteps")
        if not 0.0 <= self.p_uncond < 1.0:
            raise ScdpError("p_uncond", f"must lie in [0, 1), got {self.p_uncond}")

    def sized(self, state_dim: int, goal_dim: int, p_uncond: float | None = None) -> DiffusionConfig:
        """This shape with a task's dimensions (its state and its task space; ``Task.state_dim`` and
        ``Task.space_dim``) and, for LD's base, its goal dropout."""
        return replace(self, state_dim=state_dim, goal_dim=goal_dim, p_uncond=self.p_uncond if p_uncond is None else p_uncond)

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
        if not MIN_GOALS <= self.n_goals <= MAX_GOALS:
            raise ScdpError("n_goals", f"a scene holds a target and 1 to {MAX_GOALS - 1} distractors "
                                       f"({MIN_GOALS}..{MAX_GOALS} goals), got {self.n_goals}")
        if any(h <= 0 for h in self.hidden):
            raise ScdpError("hidden", f"widths must be > 0, got {self.hidden}")

    def sized(self, goal_dim: int, n_goals: int | None = None) -> EncoderConfig:
        """This shape for goals of ``goal_dim`` coordinates (a task's ``space_dim``), ``n_goals`` per scene."""
        return replace(self, goal_dim=goal_dim, n_goals=n_goals or self.n_goals)

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
        return first_step_of_window(self.noise_window, num_train_timesteps)

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
    # guidance on the noisiest ``window`` of the denoising steps only (k >= (1 - window) K), the
    # conditional ε(g*) alone below: the lever SCDP's film has (StyleConfig.noise_window). 1: every step
    window: float = 1.0

    def _check(self):
        if not 0.0 < self.window <= 1.0:
            raise ScdpError("window", f"must lie in (0, 1], got {self.window}")
        if self.w0 < 0:
            raise ScdpError("w0", f"must be >= 0, got {self.w0}")
        if not 0.0 <= self.alpha <= 1.0:
            raise ScdpError("alpha", f"must lie in [0, 1], got {self.alpha}")
        if not 0.0 < self.decay <= 1.0:
            raise ScdpError("decay", f"must lie in (0, 1], got {self.decay}")
        if not 0.0 < self.p_uncond < 1.0:
            raise ScdpError("p_uncond", f"must lie in (0, 1), got {self.p_uncond}")
