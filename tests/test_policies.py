import dataclasses
import hashlib
import json
import shutil

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from helpers.floats import float32_network_bound, float32_sum_bound
from scdp.config import EncoderConfig, PlanningOptions, StyleConfig, TrainConfig
from scdp.data.windows import SceneData, WindowData
from scdp.errors import ScdpError
from scdp.models.scene_encoder import SceneAutoencoder, enrich
from scdp.models.style_predictor import StylePredictor
from scdp.models.unet1d import ConditionalUnet1D
from scdp.policies import checkpoint, loaders
from scdp.policies.base import Observation
from scdp.policies.legibility_diffuser import guidance_weights
from scdp.presets import PRESETS
from scdp.tasks import BLOCK_REACH, NAVIGATION
from scdp.training import parts
from scdp.training.loop import train

TINY = PRESETS["tiny"]


@pytest.fixture(scope="module")
def tiny_ckpt(tmp_path_factory, small_datasets):
    """Tiny checkpoints of every part for Navigation (seconds)."""
    root = tmp_path_factory.mktemp("ckpt")
    ds = small_datasets["navigation"]
    parts.train_diffusion(NAVIGATION, ds, TINY, root / "base", progress=False)
    parts.train_diffusion(NAVIGATION, ds, TINY, root / "ld", ld=True, progress=False, base_dir=root / "base")
    parts.train_encoder(NAVIGATION, TINY, root / "encoder", progress=False)
    for style in ("legible", "efficient"):
        parts.train_style(NAVIGATION, ds, style, TINY, root / "base", root / "encoder", root / f"style_{style}",
                          progress=False, references=20)
    return root


def _unet():
    torch.manual_seed(0)
    return ConditionalUnet1D(action_dim=3, global_cond_dim=10, down_dims=(8, 16, 32), step_embed_dim=16).eval()


def test_film_identity_gives_exactly_the_base_output():
    net = _unet()
    x, k, c = torch.randn(4, 16, 3), torch.tensor([0, 5, 50, 99]), torch.randn(4, 10)
    ones, zeros = torch.ones(4, 32), torch.zeros(4, 32)
    with torch.no_grad():
        assert torch.equal(net(x, k, c), net(x, k, c, (ones, zeros)))
        assert not torch.allclose(net(x, k, c), net(x, k, c, (ones * 1.5, zeros + 0.2)))


def _accumulations(net: torch.nn.Module) -> tuple[int, int]:
    """The longest sum of products one output of a layer takes, and how many such layers the net has."""
    layers = [m for m in net.modules() if isinstance(m, (torch.nn.Conv1d, torch.nn.ConvTranspose1d, torch.nn.Linear))]
    longest = max(m.in_features if isinstance(m, torch.nn.Linear) else m.in_channels * m.kernel_size[0]
                  for m in layers)
    return longest, len(layers)


def test_inference_convolutions_as_one_gemm_match_the_convolution(monkeypatch):
    """Few positions at inference take the GEMM path (Conv1d); its result is the convolution's."""
    from scdp.models import gemm_conv

    net = _unet()
    calls = []
    real_pad = gemm_conv.F.pad  # only the GEMM path pads by hand (the convolution pads inside)
    monkeypatch.setattr(gemm_conv.F, "pad", lambda *a, **kw: calls.append(1) or real_pad(*a, **kw))
    x, k, c = torch.randn(1, 16, 3), torch.tensor([7]), torch.randn(1, 10)
    with torch.no_grad():
        fast = net(x, k, c)
    assert calls, "batch 1 at inference should run the convolutions as GEMMs"
    with torch.enable_grad():  # training path: oneDNN convolution, no GEMM
        calls.clear()
        slow = net(x, k, c)
        assert not calls
    longest, layers = _accumulations(net)
    bound = float32_network_bound(longest, layers) * slow.abs().max().item()
    gap = (fast - slow.detach()).abs().max().item()
    assert gap <= bound, f"GEMM path {gap:.2e} from the convolution, float32 rounding allows {bound:.2e}"
    assert bound < 1e-3  # the bound is far below what a wrong convolution gives (an O(1) error)
    with torch.no_grad():  # above GEMM_POSITIONS positions even at the deepest level (T/4): the convolution
        calls.clear()
        b = gemm_conv.GEMM_POSITIONS // 4 + 1
        net(torch.randn(b, 16, 3), torch.tensor([7] * b), torch.randn(b, 10))
        assert not calls


@pytest.mark.parametrize("stride, padding, extra", [(2, 1, 0), (2, 1, 1), (3, 0, 2), (1, 2, 0)])
def test_gemm_convolutions_match_torch_for_strides_and_paddings(stride, padding, extra):
    """The GEMM paths of Conv1d (unfold) and ConvTranspose1d (fold) against torch's own operators."""
    from scdp.models.gemm_conv import Conv1d, ConvTranspose1d

    torch.manual_seed(1)
    x = torch.randn(2, 6, 9)
    conv = Conv1d(6, 5, 3, stride=stride, padding=padding)
    up = ConvTranspose1d(6, 5, 4, stride=stride, padding=padding, output_padding=extra)
    with torch.no_grad():
        # elementwise, within the worst case of two float32 sums of C_in x K products in any order:
        # 2 gamma_n x (|W| * |x|), the convolution of the magnitudes computed in float64
        for ours, theirs in ((conv, F.conv1d), (up, F.conv_transpose1d)):
            options = dict(stride=stride, padding=padding, **({"output_padding": extra} if ours is up else {}))
            magnitude = theirs(x.double().abs(), ours.weight.double().abs(), ours.bias.double().abs(), **options)
            n = ours.in_channels * ours.kernel_size[0] + 1  # and the bias
            gap = (ours(x) - theirs(x, ours.weight, ours.bias, **options)).double().abs()
            assert (gap <= 2 * float32_sum_bound(n) * magnitude).all(), f"largest gap {gap.max():.2e}"


def test_large_weights_split_over_threads_give_the_same_output(monkeypatch):
    """The GEMM path's per-thread split of the output channels (large nets at batch 1) changes nothing."""
    from scdp.models import gemm_conv

    net = _unet()
    x, k, c = torch.randn(1, 16, 3), torch.tensor([7]), torch.randn(1, 10)
    with torch.no_grad():
        whole = net(x, k, c)
    threads = torch.get_num_threads()
    monkeypatch.setattr(gemm_conv, "SPLIT_BYTES", 0)  # split every weight
    monkeypatch.setattr(gemm_conv, "_POOL", {})
    try:
        torch.set_num_threads(3)  # more slices than cores is fine; 3 does not divide every width
        with torch.no_grad():
            split = net(x, k, c)
    finally:
        torch.set_num_threads(threads)
    assert 3 in gemm_conv._POOL  # the split ran
    gap, bound = (split - whole).abs().max().item(), float32_network_bound(*_accumulations(net)) * whole.abs().max().item()
    assert gap <= bound, f"the split output {gap:.2e} from the whole one, float32 rounding allows {bound:.2e}"


def test_film_on_every_block_touches_the_up_path_and_its_width_picks_the_blocks():
    net = _unet()
    sizes = net.film_channels("all")
    assert net.film_channels("bottleneck") == [32] and sizes == [8, 8, 16, 16, 32, 32, 32, 32, 16, 16, 8, 8]
    x, k, c = torch.randn(2, 16, 3), torch.tensor([3, 40]), torch.randn(2, 10)
    W = sum(sizes)
    with torch.no_grad():
        base = net(x, k, c)
        assert torch.equal(base, net(x, k, c, (torch.ones(2, W), torch.zeros(2, W))))
        # a shift in the last block's slice only (the up path) moves the output
        beta = torch.zeros(2, W)
        beta[:, -8:] = 0.5
        assert not torch.allclose(base, net(x, k, c, (torch.ones(2, W), beta)))
        with pytest.raises(ValueError, match="fits neither"):
            net(x, k, c, (torch.ones(2, W - 1), torch.zeros(2, W - 1)))


def test_unet_shapes_and_bottleneck():
    net = _unet()
    assert net.bottleneck_dim == 32
    assert net(torch.randn(2, 16, 3), torch.tensor([1, 2]), torch.randn(2, 10)).shape == (2, 16, 3)


def test_untrained_predictor_is_identity():
    pred = StylePredictor(StyleConfig(context_dim=8, bottleneck_dim=32, hidden=16))
    gamma, beta = pred(torch.randn(5, 8))
    assert torch.equal(gamma, torch.ones(5, 32)) and torch.equal(beta, torch.zeros(5, 32))


def test_paper_sizes():
    counts = {p: parts.dry_run(NAVIGATION, PRESETS["paper"], p)["parameters"] for p in ("base", "encoder", "style")}
    assert 65e6 <= counts["base"] <= 70e6
    assert 24e3 <= counts["encoder"] <= 28e3
    assert 0.9e6 <= counts["style"] <= 1.3e6


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


def test_diffusion_loss_decreases(tmp_path, small_datasets):
    preset = TINY.with_overrides(["base.train.epochs=10", "base.train.lr=3e-3", "base.train.warmup_steps=5"])
    _, result = parts.train_diffusion(NAVIGATION, small_datasets["navigation"], preset, tmp_path / "b", progress=False)
    assert result.losses[-1] < 0.75 * result.losses[0]


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


def test_x0_weighted_loss_by_hand(tiny_ckpt, small_datasets, monkeypatch):
    """cap 1 is the plain ε-MSE; cap c weights each window by clip((1 - ᾱ_k) / ᾱ_k, 1, c)."""
    base = loaders.load_diffusion(tiny_ckpt / "base", NAVIGATION)
    data = WindowData(small_datasets["navigation"], base.config.n_obs_steps, base.config.horizon, NAVIGATION)
    batch = data.get(torch.arange(16))
    monkeypatch.setattr(base.unet, "forward", lambda x, k, c, film=None: torch.zeros_like(x))  # ε̂ = 0: loss = noise²
    plain = base.loss(batch, generator=torch.Generator().manual_seed(1))
    weighted = base.loss(batch, generator=torch.Generator().manual_seed(1), x0_weight_cap=10.0)
    g = torch.Generator().manual_seed(1)  # the same draws as loss makes: noise, then steps
    noise = torch.randn(16, base.config.horizon, base.config.state_dim, generator=g)
    k = torch.randint(0, base.config.num_train_timesteps, (16,), generator=g)
    a = base.train_scheduler.alphas_cumprod[k]
    w = ((1 - a) / a).clamp(1.0, 10.0)
    per = noise.pow(2).mean(dim=(1, 2))
    assert plain == pytest.approx(float(per.mean()), rel=1e-6)
    assert weighted == pytest.approx(float((w * per).sum() / w.sum()), rel=1e-6)
    assert w.max() > 1.0 and weighted != pytest.approx(float(plain))


@pytest.mark.parametrize("sampler,steps", [("ddim", 3), ("dpmsolver", 5), ("ddpm", 7)])
def test_sampler_swapped_at_load_time_runs_its_step_count(tiny_ckpt, monkeypatch, sampler, steps):
    dp = loaders.load_method("dp", tiny_ckpt, NAVIGATION, PlanningOptions(sampler=sampler, steps=steps))
    assert (dp.config.sampler, dp.config.num_inference_steps) == (sampler, steps)
    calls = []
    original = dp.unet.forward
    monkeypatch.setattr(dp.unet, "forward", lambda x, k, c, film=None: calls.append(int(k[0])) or original(x, k, c, film))
    goals = torch.tensor(NAVIGATION.layouts[0], dtype=torch.float32)[None]
    obs = Observation(state_hist=torch.zeros(1, 2, 3), position=torch.zeros(1, 2), goals=goals, target=torch.tensor([0]))
    chunk = dp.act(obs, torch.Generator().manual_seed(0))
    assert len(calls) == steps and calls == sorted(calls, reverse=True)  # from noisy to clean
    assert torch.isfinite(chunk.actions).all()
    with pytest.raises(ScdpError, match="sampler"):
        loaders.load_method("dp", tiny_ckpt, NAVIGATION, PlanningOptions(sampler="euler"))


def test_guidance_weights_sum_to_one():
    for w, a in [(4.5, 0.9), (0.3, 0.1), (10.0, 0.5)]:
        assert sum(guidance_weights(w, a)) == pytest.approx(1.0)


def test_ld_decays_once_per_chunk(tiny_ckpt):
    ld = loaders.load_method("ld", tiny_ckpt, NAVIGATION)
    goals = torch.tensor(NAVIGATION.layouts[0], dtype=torch.float32)[None]
    obs = Observation(state_hist=torch.zeros(1, 2, 3), position=torch.zeros(1, 2), goals=goals, target=torch.tensor([0]))
    w0, decay = TINY.ld.guidance.w0, TINY.ld.guidance.decay  # saved in the checkpoint
    assert decay < 1
    ld.reset()
    assert ld.w == w0
    ld.act(obs, torch.Generator().manual_seed(0))
    assert ld.w == pytest.approx(w0 * decay)
    ld.act(obs, torch.Generator().manual_seed(0))
    assert ld.w == pytest.approx(w0 * decay**2)
    ld.reset()
    assert ld.w == w0


def test_ld_guidance_is_one_batched_forward(tiny_ckpt, monkeypatch):
    ld = loaders.load_method("ld", tiny_ckpt, NAVIGATION)
    ld.guidance = dataclasses.replace(ld.guidance, window=1.0)  # guided at every step (the window: test_ld_guidance.py)
    calls = []
    original = ld.policy.unet.forward
    monkeypatch.setattr(ld.policy.unet, "forward", lambda x, k, c, film=None: calls.append(len(x)) or original(x, k, c, film))
    goals = torch.tensor(NAVIGATION.layouts[0], dtype=torch.float32)[None].repeat(4, 1, 1)
    obs = Observation(state_hist=torch.zeros(4, 2, 3), position=torch.zeros(4, 2), goals=goals, target=torch.zeros(4, dtype=torch.long))
    ld.act(obs)
    assert calls == [12] * TINY.base.model.num_inference_steps  # 3 conditions x 4 scenes, once per denoising step


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


def test_windows_by_hand(small_datasets):
    ds = small_datasets["navigation"]
    w = WindowData(ds, n_obs_steps=2, horizon=4, task=NAVIGATION)
    a, b = ds.episode_bounds(1)
    first = int(np.flatnonzero(w.obs_index[:, -1].numpy() == a)[0])
    assert w.obs_index[first].tolist() == [a, a]  # the first state repeated before the start
    assert w.action_index[first].tolist() == [a, a, a + 1, a + 2]
    last = int(np.flatnonzero(w.obs_index[:, -1].numpy() == b - 1)[0])
    assert w.action_index[last].tolist() == [b - 2, b - 1, b - 1, b - 1]  # goal held after the end
    assert len(w) == ds.num_steps


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
    with pytest.raises(ScdpError, match=r"--resume: the saved run differs in data;"):
        parts.train_diffusion(NAVIGATION, other, preset, out, resume=True, progress=False)
    wider = preset.with_overrides(["base.model.step_embed_dim=32"])
    with pytest.raises(ScdpError, match=r"differs in config"):
        parts.train_diffusion(NAVIGATION, ds, wider, out, resume=True, progress=False)
    _, result = parts.train_diffusion(NAVIGATION, ds, preset, out, resume=True, progress=False)
    assert result.resumed_from > 0


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
