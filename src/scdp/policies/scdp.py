"""Style-Conditioned Diffusion Policy: a frozen base, a scene encoder and two style predictors.

At every replanning step (``act``) the style of each scene in the batch is chosen:

* ``auto``: the ellipse of ambiguity around the robot's current task-space point decides:
  a distractor inside it -> ``legible``, otherwise ``efficient`` (the predictability style);
  with ``arbitration="probabilistic"``, eq. 3 taken from the current point decides instead;
* ``blend``: both predictors, their films mixed by a smooth ambiguity score
  (:func:`scdp.ambiguity.legible_weight`): ``film = w film_legible + (1 - w) film_efficient``;
* ``legible`` / ``efficient``: that predictor for every chunk;
* ``none``: no modulation (the base policy).

The scene context ``c = encoder(enrich(goals))`` goes through the chosen predictor to give
the film (γ, β), applied in every residual block of the U-Net (both presets; the paper's
design modulates its bottleneck only: ``StyleConfig.film_blocks``) for every denoising step of
that chunk (the paper), or, with ``StyleConfig.noise_window`` w < 1, for the noisiest fraction w of the steps
only: the style then decides a chunk's coarse shape (which side, how far) and the frozen base
alone refines it, so a style that moves paths a long way still lands on the goal.
``film_scale`` s > 1 extrapolates a film away from the identity, ``γ = 1 + s (γ - 1)``,
``β = s β`` (s = 1: the predictor as trained). ``style_guidance`` g > 0 instead contrasts the
two styled noise predictions at every denoising step (one batched call of 2B):
``ε = ε_eff + (w + g (2w - 1)) (ε_leg - ε_eff)`` for legible weight w, i.e. ``ε_leg + g (ε_leg - ε_eff)``
for a legible chunk and ``ε_eff - g (ε_leg - ε_eff)`` for an efficient one.
"""

from __future__ import annotations

import numpy as np
import torch

from scdp import ambiguity
from scdp.config import StyleConfig
from scdp.errors import ScdpError
from scdp.keys import ARBITRATIONS, STYLE_MODES, STYLES, styles_needed
from scdp.models.film import Film
from scdp.models.scene_encoder import SceneAutoencoder
from scdp.models.style_predictor import StylePredictor, predictor_input
from scdp.policies.base import Chunk, Observation, WarmStart
from scdp.policies.diffusion import DiffusionPolicy
from scdp.tasks import Task

# How ``auto`` decides, from the robot's current point: the paper's ellipse, or eq. 3 itself
# (the straight path from the current point, the same closed form as the evaluation's labels).
ARBITRATION_RULES = dict(zip(ARBITRATIONS, (ambiguity.ellipse_flags, ambiguity.probabilistic_flags)))


class StyleConditionedPolicy:
    """Method ``scdp``: implements :class:`~scdp.policies.base.Planner`."""

    def __init__(self, base: DiffusionPolicy, encoder: SceneAutoencoder, predictors: dict[str, StylePredictor],
                 task: Task, style: str = "auto", film_scale: float = 1.0, style_guidance: float = 0.0,
                 arbitration: str = "ellipse"):
        if style not in STYLE_MODES:
            raise ScdpError("style", f"unknown style {style!r} (choose from {', '.join(STYLE_MODES)})")
        missing = styles_needed(style) - set(predictors)
        if missing:
            raise ScdpError("checkpoints", f"style {style!r} needs the {', '.join(sorted(missing))} predictor")
        if not film_scale > 0:
            raise ScdpError("film_scale", f"must be > 0, got {film_scale}")
        if style_guidance < 0 or (style_guidance > 0 and set(STYLES) - set(predictors)):
            raise ScdpError("style_guidance", f"needs both predictors and a value >= 0, got {style_guidance}")
        self.base, self.encoder, self.predictors, self.task, self.style = base, encoder, predictors, task, style
        if arbitration not in ARBITRATION_RULES:
            raise ScdpError("arbitration", f"unknown rule {arbitration!r} (choose from {', '.join(ARBITRATION_RULES)})")
        self.film_scale, self.style_guidance, self.arbitration = film_scale, style_guidance, arbitration
        windows = {p.config.noise_window for p in predictors.values()}
        if len(windows) > 1:
            raise ScdpError("checkpoints", f"the style predictors act on different noise windows {sorted(windows)}; retrain one")
        window = StyleConfig(noise_window=windows.pop()) if windows else StyleConfig()
        self.film_from = window.first_styled_step(base.config.num_train_timesteps)  # lowest step the film acts at

    @property
    def n_obs_steps(self) -> int:
        return self.base.n_obs_steps

    @property
    def n_action_steps(self) -> int:
        return self.base.n_action_steps

    @property
    def n_goals(self) -> int | None:
        return self.encoder.config.n_goals  # the scene encoder reads exactly this many goals

    @property
    def style_modes(self) -> tuple[str, ...]:
        """The modes the loaded predictors allow: ``none`` always, each style with its predictor, and
        ``auto``/``blend`` with both."""
        return tuple(m for m in STYLE_MODES if styles_needed(m) <= set(self.predictors))

    def set_style(self, style: str) -> None:
        if style not in self.style_modes:
            missing = ", ".join(sorted(styles_needed(style) - set(self.predictors))) if style in STYLE_MODES else ""
            raise ScdpError("style", f"{style!r} needs the {missing} predictor, which this planner did not load (load it "
                                     "as scdp)" if missing else f"one of {', '.join(self.style_modes)}, got {style!r}")
        self.style = style

    @property
    def denoiser_parameters(self) -> int:
        return self.base.denoiser_parameters

    def reset(self) -> None:
        """No per-episode state: the style is re-decided at every chunk."""

    def legible_weights(self, positions: np.ndarray, goals: np.ndarray, target: np.ndarray) -> np.ndarray:
        """(B,) weight of the legible film for this chunk: the arbitration's 0/1 for ``auto``, a smooth
        score for ``blend``, constant for a fixed style. The one place the style is decided.

        positions (B, G) current task-space points, goals (B, K, G), target (B,).
        """
        if self.style == "blend":
            return ambiguity.legible_weight(positions, goals, target, self.task.ambiguity)
        if self.style == "auto":
            return ARBITRATION_RULES[self.arbitration](positions, goals, target, self.task.ambiguity).astype(np.float64)
        return np.full(len(target), 1.0 if self.style == "legible" else 0.0)

    def style_names(self, weights: np.ndarray) -> list[str]:
        """Per-scene style label of a chunk planned with legible ``weights`` (for blend, the larger one)."""
        if self.style in ("legible", "efficient", "none"):
            return [self.style] * len(weights)
        return ["legible" if w >= 0.5 else "efficient" for w in weights]

    def choose_styles(self, positions: np.ndarray, goals: np.ndarray, target: np.ndarray) -> list[str]:
        """Per-scene style name for this chunk (see :meth:`legible_weights`)."""
        return self.style_names(self.legible_weights(positions, goals, target))

    @torch.no_grad()
    def film(self, goals: torch.Tensor, target: torch.Tensor, legible: np.ndarray,
             position: torch.Tensor) -> Film:
        """The Film (γ, β each (B, W), its placement) for per-scene legible weights ``legible`` (B,) in [0, 1];
        ``position`` (B, G) is the robot's point (needed by predictors that read the scene frame).

        Style ``none`` gives the identity; otherwise ``w film_legible + (1 - w) film_efficient``
        (a fixed style uses only its own predictor), extrapolated by ``film_scale``.
        """
        B, device = len(target), goals.device
        if self.style == "none":
            return Film.identity(B, self.base.unet.film_width("bottleneck"), "bottleneck", device)
        shape = next(iter(self.predictors.values())).config  # the loader checked both predictors agree
        C, placement = shape.film_width, shape.film_blocks
        w = torch.as_tensor(legible, dtype=goals.dtype, device=device)[:, None]
        gamma, beta = torch.zeros(B, C, device=device), torch.zeros(B, C, device=device)
        for name, weight in (("legible", w), ("efficient", 1.0 - w)):
            rows = (weight[:, 0] > 0).nonzero().flatten()
            if len(rows):
                predictor = self.predictors[name]
                x = predictor_input(predictor.config, self.encoder, self.base.normalizer.goal, goals[rows], target[rows],
                                    position[rows])
                g, b, _ = predictor(x)
                gamma[rows] += weight[rows] * g
                beta[rows] += weight[rows] * b
        return Film(1.0 + self.film_scale * (gamma - 1.0), self.film_scale * beta, placement)

    def act(self, obs: Observation, generator=None, warm: WarmStart | None = None) -> Chunk:
        weights = self.legible_weights(obs.position.cpu().numpy(), obs.goals.cpu().numpy(), obs.target.cpu().numpy())
        styles = self.style_names(weights)
        obs = obs.to(self.base.device)
        cond = self.base.observe(obs.state_hist, obs.goal)
        start, starts = self.base.warm_args(warm, obs.state_hist, weights)  # a style change starts cold
        if self.style_guidance > 0 and self.style != "none":
            plan = self._contrast_sample(cond, obs, weights, generator, start)
        else:
            plan = self.base.sample(cond, film=self.film(obs.goals, obs.target, weights, obs.position), generator=generator,
                                    film_from=self.film_from, **start)
        return Chunk(self.base.actions_to_execute(plan, obs.state_hist).cpu(), styles,
                     plan=self.base.plan_states(plan, obs.state_hist), weights=weights, starts=starts)

    def _contrast_sample(self, cond: torch.Tensor, obs: Observation, weights: np.ndarray, generator,
                         start: dict) -> torch.Tensor:
        """Sampling with ``style_guidance``: both styled predictions from one (2B) network call."""
        B = len(weights)
        films = [self.film(obs.goals, obs.target, np.full(B, w), obs.position) for w in (1.0, 0.0)]
        film = Film(torch.cat([films[0].gamma, films[1].gamma]), torch.cat([films[0].beta, films[1].beta]), films[0].placement)
        cond2 = cond.repeat(2, 1)
        w = torch.as_tensor(weights, dtype=cond.dtype, device=cond.device)
        mix = (w + self.style_guidance * (2 * w - 1))[:, None, None]

        def eps_fn(x, k, t):
            if t < self.film_from:
                return self.base.unet(x, k, cond)
            eps = self.base.unet(x.repeat(2, 1, 1), k.repeat(2), cond2, film).reshape(2, B, *x.shape[1:])
            return eps[1] + mix * (eps[0] - eps[1])

        return self.base.sample(cond, generator=generator, eps_fn=eps_fn, **start)
