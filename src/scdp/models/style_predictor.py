"""Style predictor: scene context c (B, s) -> film (γ, β), each (B, W), for the U-Net.

W is the bottleneck's width (the paper), or every residual block's width summed with
``StyleConfig.film_blocks = "all"`` (see :meth:`~scdp.models.unet1d.ConditionalUnet1D.film_channels`).

A ``layers``-deep MLP (Mish between layers) whose last layer is the (γ, β) head. The head is
zero-initialised and γ is produced as ``1 + Δγ``, so an untrained predictor returns γ = 1,
β = 0 and leaves the frozen base policy exactly as it was.

With ``StyleConfig.frame_dim > 0`` (the ``style.model.scene_frame`` option) the predictor also
reads :func:`~scdp.models.scene_encoder.scene_frame`, the distractors seen from the robot's
current point; :func:`predictor_input` builds the input the same way in training and planning.
"""

from __future__ import annotations

import torch
from torch import nn

from scdp.data.normalizer import MinMax
from scdp.models.film import Film
from scdp.models.scene_encoder import SceneAutoencoder, mlp, scene_frame


class StylePredictor(nn.Module):
    def __init__(self, config):
        super().__init__()
        self.config = config
        self.body = mlp([config.context_dim + config.frame_dim] + [config.hidden] * (config.layers - 1), final_activation=True)
        self.head = nn.Linear(config.hidden, 2 * config.film_width)
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    def forward(self, x: torch.Tensor) -> Film:
        """x (B, context_dim + frame_dim), see :func:`predictor_input` -> Film (γ, β each (B, W),
        placement ``config.film_blocks``)."""
        delta_gamma, beta = self.head(self.body(x)).chunk(2, dim=-1)
        return Film(1.0 + delta_gamma, beta, self.config.film_blocks)


def predictor_input(config, encoder: SceneAutoencoder, goal_scale: MinMax, goals: torch.Tensor, targets: torch.Tensor,
                    position: torch.Tensor) -> torch.Tensor:
    """The scene context of raw goals (B, K, d) and targets (B,), with the scene frame from the
    robot's point ``position`` (B, d) appended when ``config.frame_dim > 0``."""
    context = encoder.context(goal_scale, goals, targets)
    return torch.cat([context, scene_frame(goals, targets, position)], dim=-1) if config.frame_dim else context
