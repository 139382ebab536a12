"""Tests of scdp.models.style_predictor: the predictor, trained on the frozen base; its film's blocks, noise window and paper design."""

import hashlib
import shutil

import pytest
import torch

from helpers.tiny import TINY
from scdp.config import StyleConfig
from scdp.errors import ScdpError
from scdp.models.style_predictor import StylePredictor
from scdp.policies import loaders
from scdp.policies.base import Observation
from scdp.tasks import NAVIGATION
from scdp.training import parts


def test_untrained_predictor_is_identity():
    pred = StylePredictor(StyleConfig(context_dim=8, bottleneck_dim=32, hidden=16))
    gamma, beta, placement = pred(torch.randn(5, 8))
    assert torch.equal(gamma, torch.ones(5, 32)) and torch.equal(beta, torch.zeros(5, 32))
    assert placement == "bottleneck"  # the film names its placement (StyleConfig.film_blocks' default)


def test_base_is_bit_identical_after_style_training(tmp_path, tiny_ckpt, small_datasets):
    before = hashlib.sha256((tiny_ckpt / "base" / "model.safetensors").read_bytes()).hexdigest()
    base = loaders.load_diffusion(tiny_ckpt / "base", NAVIGATION)
    snapshot = {k: v.clone() for k, v in base.state_dict().items()}
    pred, result = parts.train_style(NAVIGATION, small_datasets["navigation"], "legible", TINY, tiny_ckpt / "base",
                                     tiny_ckpt / "encoder", tmp_path / "s", progress=False, references=20)
    assert result.steps > 0
    assert any(p.abs().sum() > 0 for p in pred.head.parameters())  # the predictor did learn
    reloaded = loaders.load_diffusion(tiny_ckpt / "base", NAVIGATION)
    for k, v in reloaded.state_dict().items():
        assert torch.equal(v, snapshot[k]), k
    assert hashlib.sha256((tiny_ckpt / "base" / "model.safetensors").read_bytes()).hexdigest() == before


def test_style_film_on_every_block_trains_loads_and_plans(tmp_path, tiny_ckpt, small_datasets):
    preset = TINY.with_overrides(["style.model.film_blocks=all"])
    base = loaders.load_diffusion(tiny_ckpt / "base", NAVIGATION)
    root = tmp_path / "ck"
    for part in ("base", "encoder"):
        shutil.copytree(tiny_ckpt / part, root / part)
    for style in ("legible", "efficient"):
        pred, _ = parts.train_style(NAVIGATION, small_datasets["navigation"], style, preset, root / "base",
                                    root / "encoder", root / f"style_{style}", progress=False, references=20)
        assert pred.config.film_width == sum(base.unet.film_channels("all")) > base.unet.bottleneck_dim
    scdp = loaders.load_method("scdp", root, NAVIGATION)
    goals = torch.tensor(NAVIGATION.layouts[0], dtype=torch.float32)[None].repeat(2, 1, 1)
    obs = Observation(state_hist=torch.zeros(2, 2, 3), position=torch.zeros(2, 2), goals=goals, target=torch.tensor([0, 1]))
    assert scdp.act(obs, torch.Generator().manual_seed(0)).actions.shape[0] == 2
    # a bottleneck-only predictor beside an every-block one is refused by name
    shutil.rmtree(root / "style_efficient")
    parts.train_style(NAVIGATION, small_datasets["navigation"], "efficient", TINY.with_overrides(["style.model.film_blocks=bottleneck"]),
                      root / "base", root / "encoder", root / "style_efficient", progress=False, references=20)
    with pytest.raises(ScdpError, match="different blocks"):
        loaders.load_method("scdp", root, NAVIGATION)


def test_noise_window_styles_only_the_noisy_steps_in_training_and_planning(tmp_path, tiny_ckpt, small_datasets, monkeypatch):
    """style.model.noise_window = 0.5: the predictor learns from k >= K/2 only and its film acts there only."""
    preset = TINY.with_overrides(["style.model.noise_window=0.5"])
    root = tmp_path / "ck"
    for part in ("base", "encoder"):
        shutil.copytree(tiny_ckpt / part, root / part)
    base = loaders.load_diffusion(root / "base", NAVIGATION)
    K = base.config.num_train_timesteps
    seen = []
    original_loss = type(base).loss
    monkeypatch.setattr(type(base), "loss", lambda self, batch, film=None, generator=None, x0_weight_cap=1.0, min_step=0:
                        seen.append(min_step) or original_loss(self, batch, film, generator, x0_weight_cap, min_step))
    for style in ("legible", "efficient"):
        parts.train_style(NAVIGATION, small_datasets["navigation"], style, preset, root / "base", root / "encoder",
                          root / f"style_{style}", progress=False, references=20)
    assert set(seen) == {K // 2}
    scdp = loaders.load_method("scdp_legible", root, NAVIGATION)
    assert scdp.film_from == K // 2
    films = []
    original = scdp.base.unet.forward
    monkeypatch.setattr(scdp.base.unet, "forward", lambda x, k, c, film=None: films.append((int(k[0]), film is not None))
                        or original(x, k, c, film))
    goals = torch.tensor(NAVIGATION.layouts[0], dtype=torch.float32)[None]
    obs = Observation(state_hist=torch.zeros(1, 2, 3), position=torch.zeros(1, 2), goals=goals, target=torch.tensor([0]))
    scdp.act(obs, torch.Generator().manual_seed(0))
    assert films and all(styled == (k >= K // 2) for k, styled in films)
    assert any(styled for _, styled in films) and not all(styled for _, styled in films)


def test_scdp_paper_plans_with_its_own_paper_design_predictors(tmp_path, tiny_ckpt, small_datasets):
    """Method scdp_paper: predictors of ``paper_style`` (bottleneck film, every step, the ellipse),
    saved as style_paper_*, on the same base as scdp's own every-block predictors."""
    preset = TINY.with_overrides(["style.model.film_blocks=all", "style.model.noise_window=0.5",
                                  "style.arbitration=probabilistic"])
    root = tmp_path / "ck"
    for part in ("base", "encoder"):
        shutil.copytree(tiny_ckpt / part, root / part)
    for part in ("style_legible", "style_efficient", "style_paper_legible", "style_paper_efficient"):
        parts.train_style(NAVIGATION, small_datasets["navigation"], part, preset, root / "base", root / "encoder",
                          root / part, progress=False, references=20)
    ours, paper = loaders.load_method("scdp", root, NAVIGATION), loaders.load_method("scdp_paper", root, NAVIGATION)
    assert paper.base.unet.state_dict().keys() == ours.base.unet.state_dict().keys()
    assert {p.config.film_blocks for p in paper.predictors.values()} == {"bottleneck"}
    assert {p.config.film_blocks for p in ours.predictors.values()} == {"all"}
    assert paper.film_from == 0 and ours.film_from > 0  # the paper's film acts at every step
    assert (paper.arbitration, ours.arbitration) == ("ellipse", "probabilistic")
    shutil.rmtree(root / "style_paper_efficient")
    with pytest.raises(ScdpError, match="style_paper_efficient"):
        loaders.load_method("scdp_paper", root, NAVIGATION)
