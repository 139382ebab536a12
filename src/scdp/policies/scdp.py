"""Style-Conditioned Diffusion Policy: a frozen base, a scene encoder and two style predictors.

At every replanning step (``act``) the style of each scene in the batch is chosen:

* ``auto``: the ellipse of ambiguity around the robot's current task-space point decides:
  a distractor inside it -> ``legible``, otherwise ``efficient`` (the predictability style);
* ``legible`` / ``efficient``: that predictor for every chunk;
* ``none``: no modulation (the base policy).

The scene context ``c = encoder(enrich(goals))`` goes through the chosen predictor to give
the film (γ, β), applied at the U-Net bottleneck for every denoising step of that chunk.
"""

from __future__ import annotations

import numpy as np
import torch

from scdp import ambiguity
from scdp.errors import ScdpError
from scdp.keys import STYLE_MODES
from scdp.models.scene_encoder import SceneAutoencoder
from scdp.models.style_predictor import StylePredictor
from scdp.policies.base import Chunk, Observation
from scdp.policies.diffusion import DiffusionPolicy


class StyleConditionedPolicy:
    """Method ``scdp``: implements :class:`~scdp.policies.base.Planner`."""

    def __init__(self, base: DiffusionPolicy, encoder: SceneAutoencoder, predictors: dict[str, StylePredictor],
                 task, style: str = "auto"):
        if style not in STYLE_MODES:
            raise ScdpError("style", f"unknown style {style!r} (choose from {', '.join(STYLE_MODES)})")
        needed = {"legible", "efficient"} if style == "auto" else ({style} - {"none"})
        missing = needed - set(predictors)
        if missing:
            raise ScdpError("checkpoints", f"style {style!r} needs the {', '.join(sorted(missing))} predictor")
        self.base, self.encoder, self.predictors, self.task, self.style = base, encoder, predictors, task, style

    @property
    def n_obs_steps(self) -> int:
        return self.base.n_obs_steps

    def reset(self) -> None:
        """No per-episode state: the style is re-decided at every chunk."""

    def choose_styles(self, positions: np.ndarray, goals: np.ndarray, target: np.ndarray) -> list[str]:
        """Per-scene style for this chunk: the ellipse arbitration when ``style='auto'``.

        positions (B, G) current task-space points, goals (B, K, G), target (B,).
        """
        if self.style != "auto":
            return [self.style] * len(target)
        flags = ambiguity.ellipse_flags(positions, goals, target, self.task.ambiguity)
        return ["legible" if f else "efficient" for f in flags]

    @torch.no_grad()
    def film(self, goals: torch.Tensor, target: torch.Tensor, styles: list[str]) -> tuple[torch.Tensor, torch.Tensor]:
        """(γ, β), each (B, C): identity rows for ``none``, the named predictor elsewhere."""
        B, C = len(styles), self.base.unet.bottleneck_dim
        gamma, beta = torch.ones(B, C), torch.zeros(B, C)
        context = self.encoder.context(self.base.normalizer.goal, goals, target)
        for name, predictor in self.predictors.items():
            rows = [i for i, s in enumerate(styles) if s == name]
            if rows:
                g, b = predictor(context[rows])
                gamma[rows], beta[rows] = g, b
        return gamma, beta

    def act(self, obs: Observation, generator: torch.Generator | None = None) -> Chunk:
        styles = self.choose_styles(obs.position.numpy(), obs.goals.numpy(), obs.target.numpy())
        film = self.film(obs.goals, obs.target, styles)
        cond = self.base.observe(obs.state_hist, obs.goal)
        plan = self.base.sample(cond, film=film, generator=generator)
        return Chunk(self.base.actions_to_execute(plan, obs.state_hist), styles)
