"""The tiny preset and a tiny conditional U-Net, shared by the model and policy tests."""

import torch

from scdp.models.unet1d import ConditionalUnet1D
from scdp.presets import PRESETS

TINY = PRESETS["tiny"]


def _unet():
    torch.manual_seed(0)
    return ConditionalUnet1D(action_dim=3, global_cond_dim=10, down_dims=(8, 16, 32), step_embed_dim=16).eval()
