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

from scdp.config import PlanningOptions, Preset
from scdp.data.normalizer import Normalizer, fit_normalizer, goal_scaling
from scdp.data.windows import SceneBatch, SceneData, TrainBatch, WindowData
from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError
from scdp.models.scene_encoder import SceneAutoencoder, enriched_scene
from scdp.models.style_predictor import StylePredictor, predictor_input
from scdp.models.unet1d import count_parameters
from scdp.policies import checkpoint
from scdp.policies.diffusion import DiffusionPolicy
from scdp.policies.loaders import load_diffusion, load_encoder
from scdp.scoring import style_subset
from scdp.tasks import Task
from scdp.training.loop import train
from scdp.training.recipe import base_dependent, part_recipe


def seeded(seed: int, build):
    """``build()`` with torch's global generator seeded, so weight initialisation is reproducible;
    the caller's generator state is restored afterwards."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        return build()


def build_diffusion(task: Task, preset: Preset, windows: WindowData | None = None, *, ld: bool = False) -> DiffusionPolicy:
    """A fresh base (or, with ``ld``, Legibility Diffuser's goal-dropout base), initialised from
    its schedule's seed; the normaliser is fitted to ``windows`` (a placeholder for dry runs)."""
    config = preset.base.model.sized(task.state_dim, task.space_dim, p_uncond=preset.ld.guidance.p_uncond if ld else 0.0)
    normalizer = fit_normalizer(windows, task, config.relative_actions) if windows is not None else Normalizer.placeholder(task)
    return seeded(preset.schedule("ld" if ld else "base").seed, lambda: DiffusionPolicy(config, normalizer, task.task_space))


def build_encoder(task: Task, preset: Preset, n_goals: int | None = None) -> SceneAutoencoder:
    """A fresh scene autoencoder for ``n_goals`` goals per scene (default: the preset's ``data.goals``)."""
    config = preset.encoder_model.sized(task.space_dim, n_goals)
    return seeded(preset.encoder.train.seed, lambda: SceneAutoencoder(config))


def build_style(preset: Preset, base: DiffusionPolicy, encoder: SceneAutoencoder, part: str = "style_legible") -> StylePredictor:
    """A fresh predictor of ``part``'s section (``style``, or ``paper_style`` for ``style_paper_*``)."""
    section = preset.style_section(part)
    model = section.model
    config = model.for_parts(encoder.config.context_dim, base.unet.bottleneck_dim, encoder.config.n_goals,
                             encoder.config.goal_dim, base.unet.film_width(model.film_blocks))
    return seeded(section.train.seed, lambda: StylePredictor(config))


def _saver(out, part, task: Task, preset: Preset, config, normalizer=None, extra=None):
    meta = {"train": preset.schedule(part).to_dict(), "overrides": list(preset.overrides or ()),
            "recipe": part_recipe(preset, part), **(extra or {})}

    def save(module, complete, seconds):
        checkpoint.save_part(out, module, part=part, task=task.name, preset=preset.name, config=config,
                             normalizer=normalizer, complete=complete, extra={**meta, "train_seconds": round(seconds, 1)})
    return save


def train_diffusion(task: Task, dataset, preset: Preset, out, *, ld: bool = False, resume=False, progress=True, device="cpu",
                    base_dir=None):
    """Train the base policy (``ld=False``) or Legibility Diffuser's goal-dropout base, on the
    first ``preset.data.base_demos`` demos of ``dataset`` (all of them when that is None).

    With ``preset.ld.init == "base"``, LD's base starts from the trained base in ``base_dir``
    (same shape, same data) and is fine-tuned with goal dropout for its schedule's steps."""
    task.check_task(dataset.task)
    n = preset.data.base_demos
    if n is not None and n < dataset.num_episodes:
        dataset = dataset.subset(range(n))
    part = "ld" if ld else "base"
    model = preset.base.model
    data = WindowData(dataset, model.n_obs_steps, model.horizon, task)
    policy = build_diffusion(task, preset, data, ld=ld)
    extra = {"demos": dataset.num_episodes}
    job = {"recipe": part_recipe(preset, part), "data": dataset.fingerprint(), "config": policy.config.to_dict()}
    if ld:
        extra["guidance"] = preset.ld.guidance.to_dict()
    if base_dependent(preset, part):
        if base_dir is None:
            raise ScdpError("--base", "LD's base is fine-tuned from the base (ld.init=base): give the base's folder")
        base = load_diffusion(base_dir, task)
        if base.config.to_dict() != {**policy.config.to_dict(), "p_uncond": 0.0}:
            raise ScdpError("--base", f"{base_dir} has another network shape than ld's; retrain it or set ld.init=scratch")
        policy.unet.load_state_dict(base.unet.state_dict())
        extra["init"] = job["base"] = checkpoint.read_meta(base_dir, "base").get("weights_sha256")
    save = _saver(out, part, task, preset, policy.config, policy.normalizer, extra)

    def loss(batch: TrainBatch, generator):
        return policy.loss(batch, generator=generator)

    result = train(policy, loss, data, preset.schedule(part), out, save, resume=resume, desc=f"{task.name} {part}",
                   progress=progress, job=job, device=device)
    return policy, result


def train_encoder(task: Task, preset: Preset, out, *, n_goals: int | None = None, resume=False, progress=True, device="cpu"):
    """Scene autoencoder on ``preset.data.encoder_scenes`` random scenes."""
    model = build_encoder(task, preset, n_goals)
    goal_scale = goal_scaling(task)  # the same scaling as the policies' goals
    data = SceneData(task, preset.data.encoder_scenes, model.config.n_goals, seed=preset.encoder.train.seed)

    def loss(batch: SceneBatch, generator):
        x = enriched_scene(goal_scale, batch.goals, batch.target)
        return torch.nn.functional.mse_loss(model(x), x)

    save = _saver(out, "encoder", task, preset, model.config, extra={"scenes": len(data)})
    result = train(model, loss, data, preset.encoder.train, out, save, resume=resume, desc=f"{task.name} encoder",
                   progress=progress, job={"recipe": part_recipe(preset, "encoder"), "config": model.config.to_dict(),
                                           "scenes": len(data)}, device=device)
    return model, result


def train_style(task: Task, dataset, part: str, preset: Preset, base_dir, encoder_dir, out, *, resume=False, progress=True,
                references: int = 100, device="cpu"):
    """One style predictor (``part``: ``style_legible``, ``style_efficient`` or their
    ``style_paper_*`` twins, trained from ``preset.paper_style``) on the top
    ``preset.data.style_fraction`` demos for its style, base frozen."""
    if part in ("legible", "efficient"):  # the style alone names the predictor of ``preset.style``
        part = f"style_{part}"
    if not part.startswith("style_") or not part.endswith(("_legible", "_efficient")):
        raise ScdpError("part", f"unknown style part {part!r}")
    style = part.rsplit("_", 1)[1]
    section = preset.style_section(part)
    task.check_task(dataset.task)
    device = resolve_device(device)
    base = load_diffusion(base_dir, task, planning=PlanningOptions(device=str(device))).requires_grad_(False).eval()
    encoder = load_encoder(encoder_dir, task, device).requires_grad_(False).eval()
    if dataset.goals.shape[1] != encoder.config.n_goals:
        raise ScdpError("--data", f"demos have {dataset.goals.shape[1]} goals per scene, the encoder {encoder.config.n_goals}")
    score = section.efficient_score if style == "efficient" else section.legible_score
    subset = style_subset(dataset, style, preset.data.style_fraction, references=references, score=score)
    predictor = build_style(preset, base, encoder, part)
    data = WindowData(subset, base.config.n_obs_steps, base.config.horizon, task).keep_early(section.early_windows)
    first_styled = predictor.config.first_styled_step(base.config.num_train_timesteps)

    def loss(batch: TrainBatch, generator):
        with torch.no_grad():
            x = predictor_input(predictor.config, encoder, base.normalizer.goal, batch.goals, batch.target,
                                batch.obs_position[:, -1])
        return base.loss(batch, film=predictor(x), generator=generator, x0_weight_cap=section.x0_weight_cap,
                         min_step=first_styled)

    save = _saver(out, part, task, preset, predictor.config, extra={"subset_demos": subset.num_episodes, "style": style,
                                                                      "arbitration": section.arbitration})
    job = {"recipe": part_recipe(preset, part), "data": subset.fingerprint(), "config": predictor.config.to_dict(),
           "base": checkpoint.read_meta(base_dir, "base").get("weights_sha256"),
           "encoder": checkpoint.read_meta(encoder_dir, "encoder").get("weights_sha256")}
    result = train(predictor, loss, data, section.train, out, save, resume=resume, desc=f"{task.name} {part}",
                   progress=progress, job=job, device=device)
    return predictor, result


def dry_run(task: Task, preset: Preset, part: str) -> dict:
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
