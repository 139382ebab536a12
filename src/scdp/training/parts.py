"""What each trainable part learns from; all of them go through :func:`scdp.training.loop.train`.

=========  ==================================  =====================================
part       data                                loss
=========  ==================================  =====================================
base       every demo window                   ε-MSE of the Diffusion Policy
ld         every demo window, goal dropout 0.1  same, for Legibility Diffuser
encoder    random scenes of the task           reconstruction MSE of the autoencoder
style      windows of the style subset          ε-MSE of the *frozen* base with (γ, β)
=========  ==================================  =====================================
"""

from __future__ import annotations

import torch

from scdp.config import EncoderConfig, Preset, StyleConfig
from scdp.data.subsets import style_subset
from scdp.errors import ScdpError
from scdp.models.scene_encoder import SceneAutoencoder, enrich
from scdp.models.style_predictor import StylePredictor
from scdp.models.unet1d import count_parameters
from scdp.policies import checkpoint
from scdp.policies.diffusion import DiffusionPolicy
from scdp.policies.normalizer import MinMax, Normalizer
from scdp.training.loop import train
from scdp.training.windows import SceneData, WindowData


def build_diffusion(task, preset: Preset, windows=None, p_uncond: float = 0.0) -> DiffusionPolicy:
    """A fresh policy; the normaliser is fitted to ``windows`` (or a unit box for dry runs)."""
    config = preset.diffusion(task, p_uncond)
    if windows is not None:
        normalizer = Normalizer.from_windows(windows, task, config.relative_actions)
    else:
        unit = MinMax.fit([-1.0] * task.state_dim, [1.0] * task.state_dim)
        goal_box = MinMax.fit(task.goal_low, task.goal_high)
        normalizer = Normalizer(unit, unit, goal_box, goal_box)
    return DiffusionPolicy(config, normalizer, task.task_space)


def seeded(seed: int, build):
    """``build()`` with torch's global generator seeded, so weight initialisation is reproducible;
    the caller's generator state is restored afterwards."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        return build()


def encoder_config(task, n_goals: int = 2) -> EncoderConfig:
    return EncoderConfig(goal_dim=task.space_dim, n_goals=n_goals)


def style_config(preset: Preset, base: DiffusionPolicy, encoder_cfg: EncoderConfig) -> StyleConfig:
    return StyleConfig(context_dim=encoder_cfg.context_dim, bottleneck_dim=base.unet.bottleneck_dim, hidden=preset.style_hidden)


def _saver(out, part, task, preset, config, normalizer=None, extra=None):
    def save(module, complete):
        checkpoint.save_part(out, module, part=part, task=task.name, preset=preset.name, config=config,
                             normalizer=normalizer, complete=complete, extra=extra)
    return save


def _check_dataset(task, dataset):
    task.check_task(dataset.task)


def train_diffusion(task, dataset, preset: Preset, out, *, ld: bool = False, resume=False, progress=True):
    """Train the base policy (``ld=False``) or Legibility Diffuser's goal-dropout base."""
    _check_dataset(task, dataset)
    part = "ld" if ld else "base"
    config = preset.diffusion(task)
    data = WindowData(dataset, config.n_obs_steps, config.horizon, task)
    policy = seeded(preset.base.seed, lambda: build_diffusion(task, preset, data, p_uncond=0.1 if ld else 0.0))
    save = _saver(out, part, task, preset, policy.config, policy.normalizer,
                  {"train": preset.base.to_dict(), "demos": dataset.num_episodes})
    result = train(policy, policy.loss, data, preset.base, out, save, resume=resume, desc=f"{task.name} {part}", progress=progress)
    return policy, result


def train_encoder(task, preset: Preset, out, *, n_goals: int = 2, resume=False, progress=True):
    """Scene autoencoder on ``preset.encoder_scenes`` random scenes."""
    cfg = encoder_config(task, n_goals)
    model = seeded(preset.encoder.seed, lambda: SceneAutoencoder(cfg))
    goal_scale = MinMax.fit(task.goal_low, task.goal_high)  # the same scaling as the policies' goals
    data = SceneData(task, preset.encoder_scenes, n_goals, seed=preset.encoder.seed)

    def loss(batch, generator):
        x = enrich(goal_scale.normalize(batch["goals"]), batch["target"])
        return torch.nn.functional.mse_loss(model(x), x)

    save = _saver(out, "encoder", task, preset, cfg, extra={"train": preset.encoder.to_dict(), "scenes": len(data)})
    result = train(model, loss, data, preset.encoder, out, save, resume=resume, desc=f"{task.name} encoder", progress=progress)
    return model, result


def train_style(task, dataset, style: str, preset: Preset, base_dir, encoder_dir, out, *, resume=False, progress=True,
                references: int = 100):
    """One style predictor on the top ``preset.style_fraction`` demos for ``style``, base frozen."""
    _check_dataset(task, dataset)
    base = checkpoint.load_diffusion(base_dir, task).requires_grad_(False).eval()
    encoder = checkpoint.load_encoder(encoder_dir, task).requires_grad_(False).eval()
    if dataset.goals.shape[1] != encoder.config.n_goals:
        raise ScdpError("--data", f"demos have {dataset.goals.shape[1]} goals per scene, the encoder {encoder.config.n_goals}")
    subset = style_subset(dataset, style, preset.style_fraction, references=references)
    cfg = style_config(preset, base, encoder.config)
    predictor = seeded(preset.style.seed, lambda: StylePredictor(cfg))
    data = WindowData(subset, base.config.n_obs_steps, base.config.horizon, task)

    def loss(batch, generator):
        with torch.no_grad():
            context = encoder.encode(enrich(base.normalizer.goal.normalize(batch["goals"]), batch["target"]))
        return base.loss(batch, style=predictor(context), generator=generator)

    save = _saver(out, f"style_{style}", task, preset, cfg,
                  extra={"train": preset.style.to_dict(), "subset_demos": subset.num_episodes, "style": style})
    result = train(predictor, loss, data, preset.style, out, save, resume=resume, desc=f"{task.name} style_{style}", progress=progress)
    return predictor, result


def dry_run(task, preset: Preset, part: str) -> dict:
    """Build a part without data or training; report its parameter count."""
    if part in ("base", "ld"):
        model = build_diffusion(task, preset, p_uncond=0.1 if part == "ld" else 0.0)
    elif part == "encoder":  # the paper counts the encoder half of the autoencoder
        autoencoder = SceneAutoencoder(encoder_config(task))
        return {"part": part, "parameters": count_parameters(autoencoder.encoder),
                "autoencoder_parameters": count_parameters(autoencoder)}
    elif part == "style":
        base = build_diffusion(task, preset)
        model = StylePredictor(style_config(preset, base, encoder_config(task)))
    else:
        raise ScdpError("part", f"unknown part {part!r}")
    return {"part": part, "parameters": count_parameters(model)}
