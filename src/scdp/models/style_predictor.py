"""Style predictor: scene context c (B, s) -> film (γ, β), each (B, C), for the U-Net bottleneck.

A ``layers``-deep MLP (Mish between layers) whose last layer is the (γ, β) head. The head is
zero-initialised and γ is produced as ``1 + Δγ``, so an untrained predictor returns γ = 1,
β = 0 and leaves the frozen base policy exactly as it was.
"""

from __future__ import annotations

import torch
from torch import nn

from scdp.models.scene_encoder import mlp


class StylePredictor(nn.Module):
    def __init__(self, config):
        super().__init__()
        self.config = config
        self.body = mlp([config.context_dim] + [config.hidden] * (config.layers - 1), final_activation=True)
        self.head = nn.Linear(config.hidden, 2 * config.bottleneck_dim)
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    def forward(self, context: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        delta_gamma, beta = self.head(self.body(context)).chunk(2, dim=-1)
        return 1.0 + delta_gamma, beta
