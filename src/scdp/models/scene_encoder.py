"""Scene autoencoder: enriched goal vectors -> context c -> reconstruction.

A scene with target g* and distractors g-_1..g-_N becomes (paper, Scene Encoding)::

    x = [g*, 0, 0,  g-_1, r_1, j_1,  ...,  g-_N, r_N, j_N]      r_i = g-_i - g*,  j_i = |r_i|

of size (N + 1)(2d + 1) for d-dimensional goals. Goals are first min-max scaled to [-1, 1]
over the task's goal box, so r and j are scale-free too. The encoder is a 3-layer MLP
(hidden 128, 128 -> context 64 at the paper setting: ~26 k parameters for 2-D goals); the
decoder mirrors it. A model is built for a fixed number of goals (``EncoderConfig.n_goals``).
"""

from __future__ import annotations

import torch
from torch import nn

from scdp.data.normalizer import MinMax


def target_first(goals: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
    """goals (B, K, d), targets (B,) -> (B, K, d): g* first, then the others in their original order."""
    B, K, d = goals.shape
    idx = torch.arange(K, device=goals.device).expand(B, K)
    order = torch.argsort((idx != targets[:, None]).int(), dim=1, stable=True)
    return torch.gather(goals, 1, order[..., None].expand(B, K, d))


def enrich(goals: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
    """goals (B, K, d) already scaled, targets (B,) -> enriched vectors (B, K * (2d + 1)), g* first."""
    B, K, d = goals.shape
    ordered = target_first(goals, targets)
    rel = ordered - ordered[:, :1]
    dist = rel.norm(dim=-1, keepdim=True)
    return torch.cat([ordered, rel, dist], dim=-1).reshape(B, K * (2 * d + 1))


def enriched_scene(goal_scale: MinMax, goals: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
    """Raw goals (B, K, d), targets (B,) -> enriched vectors (B, K * (2d + 1)) over scaled goals."""
    return enrich(goal_scale.normalize(goals), targets)


def scene_frame(goals: torch.Tensor, targets: torch.Tensor, position: torch.Tensor) -> torch.Tensor:
    """Each distractor seen from the robot, in the frame of its straight line to g*.

    goals (B, K, d) raw, targets (B,), position (B, d) -> (B, (K - 1) * f): for every
    distractor (in the order of :func:`enrich`), its coordinate ``along`` the line p -> g* and
    its signed offset ``across`` it in the xy plane (positive: left of the line), plus its
    height difference for d = 3; all over ``||g* - p|| + ||g⁻ - p||``. The sign of ``across``
    says on which side a legible path must bend, which a predictor reads far more easily than
    from the context. The scale keeps every value in [-1, 1] wherever the robot is (over
    ``||g* - p||`` alone they grow without bound as the robot nears g*, far outside anything a
    predictor saw early in its demos) and loses nothing: the distance ratio
    ``||g⁻ - p|| / ||g* - p|| = s / (1 - s)`` with ``s`` the feature vector's norm.
    """
    B, K, d = goals.shape
    ordered = target_first(goals, targets)
    axis = ordered[:, 0] - position  # (B, d)
    dist = axis.norm(dim=-1, keepdim=True).clamp_min(1e-6)
    rel = ordered[:, 1:] - position[:, None]  # (B, K-1, d)
    u = axis / dist
    scale = dist + rel.norm(dim=-1)  # (B, K-1)
    along = (rel * u[:, None]).sum(-1) / scale
    flat = axis[:, :2] / axis[:, :2].norm(dim=-1, keepdim=True).clamp_min(1e-6)
    across = (flat[:, None, 0] * rel[..., 1] - flat[:, None, 1] * rel[..., 0]) / scale
    parts = [along, across] + ([(rel[..., 2]) / scale] if d == 3 else [])
    return torch.stack(parts, dim=-1).reshape(B, -1)


def mlp(sizes, final_activation: bool = False) -> nn.Sequential:
    layers = []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        layers.append(nn.Linear(a, b))
        if i < len(sizes) - 2 or final_activation:
            layers.append(nn.Mish())
    return nn.Sequential(*layers)


class SceneAutoencoder(nn.Module):
    """``encode(x (B, in)) -> c (B, context)``; ``forward`` returns the reconstruction (B, in)."""

    def __init__(self, config):
        super().__init__()
        self.config = config
        sizes = [config.input_dim, *config.hidden, config.context_dim]
        self.encoder = mlp(sizes)
        self.decoder = mlp(sizes[::-1])

    def encode(self, x: torch.Tensor) -> torch.Tensor:
        return self.encoder(x)

    def context(self, goal_scale: MinMax, goals: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
        """The scene context c (B, context) of raw goals (B, K, d) and targets (B,): goals -> enrich -> encode."""
        return self.encoder(enriched_scene(goal_scale, goals, targets))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.decoder(self.encoder(x))
