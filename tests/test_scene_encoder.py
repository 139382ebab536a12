"""Tests of scdp.models.scene_encoder: the enriched scene features and the scene autoencoder."""

import numpy as np
import pytest
import torch

from helpers.tiny import TINY
from scdp.config import EncoderConfig
from scdp.data.windows import SceneData
from scdp.models.scene_encoder import SceneAutoencoder, enrich
from scdp.tasks import NAVIGATION
from scdp.training import parts


def test_enrich_by_hand():
    goals = torch.tensor([[[0.0, 0.0], [3.0, 4.0], [1.0, 0.0]]])
    x = enrich(goals, torch.tensor([1]))  # target is goal 1: it comes first with zero r and j
    expected = [3, 4, 0, 0, 0,  0, 0, -3, -4, 5,  1, 0, -2, -4, np.sqrt(20)]
    assert torch.allclose(x[0], torch.tensor(expected, dtype=torch.float32))


@pytest.mark.parametrize("n_goals", [3, 4, 5])
def test_encoder_handles_more_goals(n_goals):
    model = SceneAutoencoder(EncoderConfig(goal_dim=2, n_goals=n_goals))
    data = SceneData(NAVIGATION, 64, n_goals, seed=0)
    batch = data.get(torch.arange(8))
    x = enrich(batch.goals, batch.target)
    assert x.shape == (8, n_goals * 5)
    assert model.encode(x).shape == (8, 64) and model(x).shape == x.shape


def test_encoder_reconstruction_error_drops(tmp_path):
    preset = TINY.with_overrides(['encoder.train={"epochs": 30, "batch_size": 64, "lr": 3e-3, "warmup_steps": 0, "ema_power": null}'])
    _, result = parts.train_encoder(NAVIGATION, preset, tmp_path / "enc", progress=False)
    assert result.losses[-1] < 0.3 * result.losses[0]
