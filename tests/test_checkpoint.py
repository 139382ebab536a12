"""Tests of scdp.policies.checkpoint (through scdp.policies.loaders): saving, loading and refusing damaged checkpoints."""

import json
import shutil

import pytest
import torch

from scdp.errors import ScdpError
from scdp.policies import checkpoint, loaders
from scdp.tasks import BLOCK_REACH, NAVIGATION


def test_checkpoint_round_trip(tiny_ckpt, tmp_path):
    base = loaders.load_diffusion(tiny_ckpt / "base", NAVIGATION)
    checkpoint.save_part(tmp_path / "copy", base, part="base", task="navigation", preset="tiny",
                         config=base.config, normalizer=base.normalizer)
    again = loaders.load_diffusion(tmp_path / "copy", NAVIGATION)
    x, k, c = torch.randn(2, 16, 3), torch.tensor([3, 7]), torch.randn(2, base.config.global_cond_dim)
    with torch.no_grad():
        assert torch.equal(base.unet(x, k, c), again.unet(x, k, c))
    assert again.normalizer == base.normalizer
    meta = json.loads((tmp_path / "copy" / "config.json").read_text())
    assert meta["format_version"] == 1 and meta["task"] == "navigation" and meta["parameters"] > 0


def test_checkpoint_refusals(tiny_ckpt, tmp_path):
    import shutil

    with pytest.raises(ScdpError, match="trained for 'navigation'") as err:
        loaders.load_diffusion(tiny_ckpt / "base", BLOCK_REACH)
    assert err.value.field == "task"
    with pytest.raises(ScdpError, match="no base checkpoint"):
        loaders.load_method("dp", tmp_path, NAVIGATION)
    bad = tmp_path / "corrupt"
    shutil.copytree(tiny_ckpt / "base", bad)
    (bad / "model.safetensors").write_bytes(b"\x00garbage" * 10)
    with pytest.raises(ScdpError, match="SHA-256"):
        loaders.load_diffusion(bad, NAVIGATION)
    mismatch = tmp_path / "mismatch"
    shutil.copytree(tiny_ckpt / "base", mismatch)
    meta = json.loads((mismatch / "config.json").read_text())
    meta["config"]["down_dims"] = [16, 32, 64]
    (mismatch / "config.json").write_text(json.dumps(meta))
    with pytest.raises(ScdpError, match="do not fit"):
        loaders.load_diffusion(mismatch, NAVIGATION)
    (mismatch / "config.json").write_text("{broken")
    with pytest.raises(ScdpError, match="corrupt"):
        loaders.load_diffusion(mismatch, NAVIGATION)


def _edited_base(tiny_ckpt, tmp_path, edit):
    folder = tmp_path / "edited"
    shutil.copytree(tiny_ckpt / "base", folder)
    meta = json.loads((folder / "config.json").read_text())
    (folder / "config.json").write_text(json.dumps(edit(meta)))
    return folder


@pytest.mark.parametrize("edit, inner", [  # every refusal names the checkpoint; a bad entry inside names it too
    (lambda m: [m], ""),
    (lambda m: {**m, "config": {**m["config"], "horizon": "sixteen"}}, "config.json horizon:"),
    (lambda m: {k: v for k, v in m.items() if k != "normalizer"}, "config.json normalizer:"),
    (lambda m: {**m, "normalizer": {**m["normalizer"], "state": {"low": [0.0], "high": [1.0]}}}, "config.json normalizer/state:"),
    (lambda m: {**m, "normalizer": {**m["normalizer"], "goal": {"low": [1.0, 1.0], "high": [0.0, 0.0]}}},
     "config.json normalizer/goal:"),
    (lambda m: {**m, "config": [1, 2]}, ""),
])
def test_damaged_checkpoint_configs_are_refused_by_field(tiny_ckpt, tmp_path, edit, inner):
    with pytest.raises(ScdpError) as err:
        loaders.load_diffusion(_edited_base(tiny_ckpt, tmp_path, edit), NAVIGATION)
    assert err.value.field == "checkpoints/base" and err.value.message.startswith(inner), str(err.value)


def test_a_flipped_byte_in_the_weights_is_refused(tiny_ckpt, tmp_path):
    folder = tmp_path / "flipped"
    shutil.copytree(tiny_ckpt / "base", folder)
    data = bytearray((folder / "model.safetensors").read_bytes())
    data[-10] ^= 0x01  # inside the last tensor: still a readable safetensors file
    (folder / "model.safetensors").write_bytes(bytes(data))
    with pytest.raises(ScdpError, match="SHA-256"):
        loaders.load_diffusion(folder, NAVIGATION)
