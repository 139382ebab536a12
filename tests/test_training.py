"""Tests of scdp.training: the training loop (resume, min_steps) and the parts (sizes, base demos, resume refusals)."""

import json

import pytest
import torch

from helpers.tiny import TINY
from scdp.config import TrainConfig
from scdp.data.windows import SceneData
from scdp.errors import ScdpError
from scdp.presets import PRESETS
from scdp.tasks import NAVIGATION
from scdp.training import parts
from scdp.training.loop import train


def test_paper_sizes():
    counts = {p: parts.dry_run(NAVIGATION, PRESETS["paper"], p)["parameters"] for p in ("base", "encoder", "style")}
    assert 65e6 <= counts["base"] <= 70e6
    assert 24e3 <= counts["encoder"] <= 28e3
    assert 0.9e6 <= counts["style"] <= 1.3e6


def test_resume_continues_from_the_last_checkpoint(tmp_path):
    model = torch.nn.Linear(3, 1)
    data = SceneData(NAVIGATION, 64, 2, seed=0)
    cfg = TrainConfig(epochs=4, batch_size=16, lr=1e-2, warmup_steps=0, ema_power=0.75, checkpoint_every=5)
    saved = []

    def loss(batch, generator):
        return model(batch.goals[:, 0, :].repeat(1, 2)[:, :3]).pow(2).mean()

    class Stop(Exception):
        pass

    def save_then_crash(module, complete, seconds):
        saved.append(complete)
        if len(saved) == 2:
            raise Stop  # the process dies right after its second checkpoint (step 10)

    with pytest.raises(Stop):
        train(model, loss, data, cfg, tmp_path, save_then_crash, progress=False)
    result = train(torch.nn.Linear(3, 1), loss, data, cfg, tmp_path, lambda m, c, s: None, resume=True, progress=False)
    assert result.resumed_from == 10 and result.steps == 16
    assert len(result.losses) == 4


def test_min_steps_extends_short_datasets(tmp_path):
    model = torch.nn.Linear(2, 1)
    data = SceneData(NAVIGATION, 32, 2, seed=0)  # 2 steps per epoch at batch 16
    cfg = TrainConfig(epochs=1, batch_size=16, lr=1e-3, warmup_steps=0, ema_power=None, min_steps=7)
    result = train(model, lambda b, generator: model(b.goals[:, 0]).pow(2).mean(), data, cfg, tmp_path,
                   lambda m, c, s: None, progress=False)
    assert result.steps == 7 and len(result.losses) == 4  # three full epochs and one partial


def test_base_trains_on_the_first_base_demos_only(tmp_path, small_datasets):
    ds = small_datasets["navigation"]
    preset = TINY.with_overrides([f"data.num_demos={ds.num_episodes}", "data.base_demos=2"])
    parts.train_diffusion(NAVIGATION, ds, preset, tmp_path / "b", progress=False)
    meta = json.loads((tmp_path / "b" / "config.json").read_text())
    assert meta["demos"] == 2 and ds.num_episodes > 2


def test_resume_refuses_a_changed_job_and_names_what_changed(tmp_path, small_datasets):
    ds = small_datasets["navigation"]
    preset = TINY.with_overrides(["base.train.epochs=3", "base.train.checkpoint_every=2"])
    out = tmp_path / "b"
    parts.train_diffusion(NAVIGATION, ds, preset, out, progress=False)
    (out / "config.json").unlink()  # as if it had died after a checkpoint
    other = ds.subset(range(ds.num_episodes - 1))
    with pytest.raises(ScdpError, match=r"--resume: the saved run differs in demos;"):
        parts.train_diffusion(NAVIGATION, other, preset, out, resume=True, progress=False)
    wider = preset.with_overrides(["base.model.step_embed_dim=32"])
    with pytest.raises(ScdpError, match=r"differs in recipe"):
        parts.train_diffusion(NAVIGATION, ds, wider, out, resume=True, progress=False)
    _, result = parts.train_diffusion(NAVIGATION, ds, preset, out, resume=True, progress=False)
    assert result.resumed_from > 0
