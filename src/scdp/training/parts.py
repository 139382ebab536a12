"""What each trainable part learns from; all of them go through :func:`scdp.training.loop.train`.

=========  ==================================  =====================================
part       data                                loss
=========  ==================================  =====================================
base       every demo window                   ε-MSE of the Diffusion Policy
ld         every demo window, goal dropout     same, for Legibility Diffuser
encoder    random scenes of the task           reconstruction MSE of the autoencoder
style      windows of the style subset          ε-MSE of the *frozen* base with film (γ, β)
=========  ==================================  =====================================

Each part's model shape and schedule come from its preset section (``preset.base``,
``preset.encoder``, ``preset.style``, ``preset.ld``; :meth:`Preset.schedule`). Every
checkpoint records the preset's name and overrides.
"""

from __future__ import annotations

import torch

from scdp.config import Preset
from scdp.data.normalizer import Normalizer, fit_normalizer, goal_scaling
from scdp.data.subsets import style_subset
from scdp.data.windows import SceneBatch, SceneData, TrainBatch, WindowData
from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError
from scdp.models.scene_encoder import SceneAutoencoder, enriched_scene
from scdp.models.style_predictor import StylePredictor, predictor_input
from scdp.models.unet1d import count_parameters
from scdp.policies import checkpoint
from scdp.policies.diffusion import DiffusionPolicy
from scdp.policies.loaders import load_diffusion, load_encoder
from scdp.training.loop import train


def seeded(seed: int, build):
    """``build()`` with torch's global generator seeded, so weight initialisation is reproducible;
    the caller's generator state is restored afterwards."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        return build()


def build_diffusion(task, preset: Preset, windows: WindowData | None = None, *, ld: bool = False) -> DiffusionPolicy:
    """A fresh base (or, with ``ld``, Legibility Diffuser's goal-dropout base), initialised from
    its schedule's seed; the normaliser is fitted to ``windows`` (a placeholder for dry runs)."""
    config = preset.base.model.for_task(task, p_uncond=preset.ld.guidance.p_uncond if ld else 0.0)
    normalizer = fit_normalizer(windows, task, config.relative_actions) if windows is not None else Normalizer.placeholder(task)
    return seeded(preset.schedule("ld" if ld else "base").seed, lambda: DiffusionPolicy(config, normalizer, task.task_space))


def build_encoder(task, preset: Preset, n_goals: int | None = None) -> SceneAutoencoder:
    config = preset.encoder.model.for_task(task, n_goals)
    return seeded(preset.encoder.train.seed, lambda: SceneAutoencoder(config))


def build_style(preset: Preset, base: DiffusionPolicy, encoder: SceneAutoencoder) -> StylePredictor:
    model = preset.style.model
    config = model.for_parts(encoder.config.context_dim, base.unet.bottleneck_dim, encoder.config.n_goals,
                             encoder.config.goal_dim, sum(base.unet.film_channels(model.film_blocks)))
    return seeded(preset.style.train.seed, lambda: StylePredictor(config))


def _saver(out, part, task, preset: Preset, config, normalizer=None, extra=None):
    meta = {"train": preset.schedule(part).to_dict(), "overrides": list(preset.overrides or ()), **preset.recipe(part),
            **(extra or {})}

    def save(module, complete, seconds):
        checkpoint.save_part(out, module, part=part, task=task.name, preset=preset.name, config=config,
                             normalizer=normalizer, complete=complete, extra={**meta, "train_seconds": round(seconds, 1)})
    return save


def train_diffusion(task, dataset, preset: Preset, out, *, ld: bool = False, resume=False, progress=True, device="cpu"):
    """Train the base policy (``ld=False``) or Legibility Diffuser's goal-dropout base, on the
    first ``preset.data.base_demos`` demos of ``dataset`` (all of them when that is None)."""
    task.check_task(dataset.task)
    n = preset.data.base_demos
    if n is not None and n < dataset.num_episodes:
        dataset = dataset.subset(range(n))
    part = "ld" if ld else "base"
    model = preset.base.model
    data = WindowData(dataset, model.n_obs_steps, model.horizon, task)
    policy = build_diffusion(task, preset, data, ld=ld)
    extra = {"demos": dataset.num_episodes}
    if ld:
        extra["guidance"] = preset.ld.guidance.to_dict()
    save = _saver(out, part, task, preset, policy.config, policy.normalizer, extra)

    def loss(batch: TrainBatch, generator):
        return policy.loss(batch, generator=generator)

    job = {"data": dataset.fingerprint(), "config": policy.config.to_dict()}
    result = train(policy, loss, data, preset.schedule(part), out, save, resume=resume, desc=f"{task.name} {part}",
                   progress=progress, job=job, device=device)
    return policy, result


def train_encoder(task, preset: Preset, out, *, n_goals: int | None = None, resume=False, progress=True, device="cpu"):
    """Scene autoencoder on ``preset.data.encoder_scenes`` random scenes."""
    model = build_encoder(task, preset, n_goals)
    goal_scale = goal_scaling(task)  # the same scaling as the policies' goals
    data = SceneData(task, preset.data.encoder_scenes, model.config.n_goals, seed=preset.encoder.train.seed)

    def loss(batch: SceneBatch, generator):
        x = enriched_scene(goal_scale, batch.goals, batch.target)
        return torch.nn.functional.mse_loss(model(x), x)

    save = _saver(out, "encoder", task, preset, model.config, extra={"scenes": len(data)})
    result = train(model, loss, data, preset.encoder.train, out, save, resume=resume, desc=f"{task.name} encoder",
                   progress=progress, job={"config": model.config.to_dict(), "scenes": len(data)}, device=device)
    return model, result


def train_style(task, dataset, style: str, preset: Preset, base_dir, encoder_dir, out, *, resume=False, progress=True,
                references: int = 100, device="cpu"):
    """One style predictor on the top ``preset.data.style_fraction`` demos for ``style``, base frozen."""
    task.check_task(dataset.task)
    device = resolve_device(device)
    base = load_diffusion(base_dir, task, device=device).requires_grad_(False).eval()
    encoder = load_encoder(encoder_dir, task, device).requires_grad_(False).eval()
    if dataset.goals.shape[1] != encoder.config.n_goals:
        raise ScdpError("--data", f"demos have {dataset.goals.shape[1]} goals per scene, the encoder {encoder.config.n_goals}")
    score = preset.style.efficient_score if style == "efficient" else None  # None: the paper's ranking
    subset = style_subset(dataset, style, preset.data.style_fraction, references=references, score=score)
    predictor = build_style(preset, base, encoder)
    data = WindowData(subset, base.config.n_obs_steps, base.config.horizon, task).keep_early(preset.style.early_windows)
    first_styled = predictor.config.first_styled_step(base.config.num_train_timesteps)

    def loss(batch: TrainBatch, generator):
        with torch.no_grad():
            x = predictor_input(predictor.config, encoder, base.normalizer.goal, batch.goals, batch.target,
                                batch.obs_position[:, -1])
        return base.loss(batch, film=predictor(x), generator=generator, x0_weight_cap=preset.style.x0_weight_cap,
                         min_step=first_styled)

    part = f"style_{style}"
    save = _saver(out, part, task, preset, predictor.config, extra={"subset_demos": subset.num_episodes, "style": style,
                                                                      "arbitration": preset.style.arbitration})
    job = {"data": subset.fingerprint(), "config": predictor.config.to_dict(), "early_windows": preset.style.early_windows,
           "score": subset.attrs["score"],
           "x0_weight_cap": preset.style.x0_weight_cap,
           "base": checkpoint.read_meta(base_dir, "base").get("weights_sha256")}
    result = train(predictor, loss, data, preset.style.train, out, save, resume=resume, desc=f"{task.name} {part}",
                   progress=progress, job=job, device=device)
    return predictor, result


def dry_run(task, preset: Preset, part: str) -> dict:
    """Build a part without data or training; report its parameter count."""
    if part in ("base", "ld"):
        model = build_diffusion(task, preset, ld=part == "ld")
    elif part == "encoder":  # the paper counts the encoder half of the autoencoder
        autoencoder = build_encoder(task, preset)
        return {"part": part, "parameters": count_parameters(autoencoder.encoder),
                "autoencoder_parameters": count_parameters(autoencoder)}
    elif part == "style":
        model = build_style(preset, build_diffusion(task, preset), build_encoder(task, preset))
    else:
        raise ScdpError("part", f"unknown part {part!r}")
    return {"part": part, "parameters": count_parameters(model)}
