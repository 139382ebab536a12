"""What each trainable part learns from; all of them go through :func:`scdp.training.loop.train`.

=========  ==================================  =====================================
part       data                                loss
=========  ==================================  =====================================
base       every demo window                   ε-MSE of the Diffusion Policy
ld         every demo window, goal dropout     same, for Legibility Diffuser
encoder    random scenes of the task           reconstruction MSE of the autoencoder
style      windows of the style subset (or of  ε-MSE of the *frozen* base with film (γ, β)
           steps ranked by the path left)
student    every demo window, a film each      MSE to the frozen base's DDIM chunk
                                               (:mod:`scdp.training.distill`)
=========  ==================================  =====================================

Each part's model shape and schedule come from its preset section (``preset.base``,
``preset.encoder``, ``preset.style``, ``preset.ld``; :meth:`Preset.schedule`). Every
checkpoint records the preset's name and overrides.
"""

from __future__ import annotations

from pathlib import Path

import torch

from scdp.config import DiffusionConfig, PlanningOptions, Preset
from scdp.data.normalizer import Normalizer, fit_normalizer, goal_scaling
from scdp.data.windows import SceneBatch, SceneData, TrainBatch, WindowData
from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError
from scdp.keys import STUDENT_PART, STYLES, part_design, part_style, style_part
from scdp.models.scene_encoder import SceneAutoencoder, enriched_scene
from scdp.models.style_predictor import StylePredictor, predictor_input
from scdp.models.unet1d import count_parameters
from scdp.policies import checkpoint
from scdp.policies.diffusion import DiffusionPolicy
from scdp.policies.loaders import load_diffusion, load_encoder, load_method
from scdp.scoring import style_subset
from scdp.scoring.rest import rest_scores, top_by_progress
from scdp.tasks import Task
from scdp.training.distill import TEACHER_SAMPLER, Distillation
from scdp.training.loop import train
from scdp.training.made_from import made_from, styles_hash, weights_hash, write_record
from scdp.training.recipe import base_dependent


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


def build_style(preset: Preset, base: DiffusionPolicy, encoder: SceneAutoencoder, part: str = style_part("legible")) -> StylePredictor:
    """A fresh predictor of ``part``'s section (``style``, or ``paper_style`` for ``style_paper_*``)."""
    section = preset.style_section(part)
    model = section.model
    config = model.for_parts(encoder.config.context_dim, base.unet.bottleneck_dim, encoder.config.n_goals,
                             encoder.config.goal_dim, base.unet.film_width(model.film_blocks))
    return seeded(section.train.seed, lambda: StylePredictor(config))


def _saver(out, part, task: Task, preset: Preset, record: dict, config, normalizer=None, extra=None):
    """``save(module, complete, seconds)``: the part's weights and ``config.json``, and, once it is
    finished, its made-from ``record`` (:mod:`scdp.training.made_from`) beside them."""
    meta = {"train": preset.schedule(part).to_dict(), "overrides": list(preset.overrides or ()), **(extra or {})}

    def save(module, complete, seconds):
        checkpoint.save_part(out, module, part=part, task=task.name, preset=preset.name, config=config,
                             normalizer=normalizer, complete=complete, extra={**meta, "train_seconds": round(seconds, 1)})
        if complete:
            write_record(out, record)
    return save


def _record(record: dict | None, task: Task, preset: Preset, part: str, dataset=None, base_dir=None, encoder_dir=None) -> dict:
    """``record`` when the caller computed it (``reproduce`` has), else the part's made-from record
    from the full ``dataset`` and the weights in ``base_dir``, ``encoder_dir`` and (for the student)
    the style predictors beside the base."""
    if record is not None:
        return record
    return made_from(task, preset, part, demos=dataset.fingerprint() if dataset is not None else None,
                     base=weights_hash(base_dir) if base_dir is not None else None,
                     encoder=weights_hash(encoder_dir) if encoder_dir is not None else None,
                     styles=styles_hash(Path(base_dir).parent) if part == STUDENT_PART else None)


def train_diffusion(task: Task, dataset, preset: Preset, out, *, ld: bool = False, resume=False, progress=True, device="cpu",
                    base_dir=None, record: dict | None = None):
    """Train the base policy (``ld=False``) or Legibility Diffuser's goal-dropout base, on the
    first ``preset.data.base_demos`` demos of ``dataset`` (all of them when that is None).

    With ``preset.ld.init == "base"``, LD's base starts from the trained base in ``base_dir``
    (same shape, same data) and is fine-tuned with goal dropout for its schedule's steps. ``record``:
    what it is made from (:mod:`scdp.training.made_from`; computed here when None)."""
    task.check_task(dataset.task)
    part = "ld" if ld else "base"
    if base_dependent(preset, part) and base_dir is None:
        raise ScdpError("--base", "LD's base is fine-tuned from the base (ld.init=base): give the base's folder")
    job = _record(record, task, preset, part, dataset, base_dir if base_dependent(preset, part) else None)
    n = preset.data.base_demos
    if n is not None and n < dataset.num_episodes:
        dataset = dataset.subset(range(n))
    model = preset.base.model
    data = WindowData(dataset, model.n_obs_steps, model.horizon, task)
    policy = build_diffusion(task, preset, data, ld=ld)
    extra = {"demos": dataset.num_episodes}
    if ld:
        extra["guidance"] = preset.ld.guidance.to_dict()
    if base_dependent(preset, part):
        base = load_diffusion(base_dir, task)
        if base.config.to_dict() != {**policy.config.to_dict(), "p_uncond": 0.0}:
            raise ScdpError("--base", f"{base_dir} has another network shape than ld's; retrain it or set ld.init=scratch")
        policy.unet.load_state_dict(base.unet.state_dict())
        extra["init"] = checkpoint.read_meta(base_dir, "base").get("weights_sha256")
    save = _saver(out, part, task, preset, job, policy.config, policy.normalizer, extra)

    def loss(batch: TrainBatch, generator):
        return policy.loss(batch, generator=generator)

    result = train(policy, loss, data, preset.schedule(part), out, save, resume=resume, desc=f"{task.name} {part}",
                   progress=progress, job=job, device=device)
    return policy, result


def train_encoder(task: Task, preset: Preset, out, *, n_goals: int | None = None, resume=False, progress=True, device="cpu",
                  record: dict | None = None):
    """Scene autoencoder on ``preset.data.encoder_scenes`` random scenes."""
    job = _record(record, task, preset, "encoder")
    model = build_encoder(task, preset, n_goals)
    goal_scale = goal_scaling(task)  # the same scaling as the policies' goals
    data = SceneData(task, preset.data.encoder_scenes, model.config.n_goals, seed=preset.encoder.train.seed)

    def loss(batch: SceneBatch, generator):
        x = enriched_scene(goal_scale, batch.goals, batch.target)
        return torch.nn.functional.mse_loss(model(x), x)

    save = _saver(out, "encoder", task, preset, job, model.config, extra={"scenes": len(data)})
    result = train(model, loss, data, preset.encoder.train, out, save, resume=resume, desc=f"{task.name} encoder",
                   progress=progress, job={**job, "goals": model.config.n_goals}, device=device)
    return model, result


def train_style(task: Task, dataset, part: str, preset: Preset, base_dir, encoder_dir, out, *, resume=False, progress=True,
                references: int = 100, device="cpu", record: dict | None = None):
    """One style predictor (``part``: ``style_legible``, ``style_efficient`` or their
    ``style_paper_*`` twins, trained from ``preset.paper_style``) on the top
    ``preset.data.style_fraction`` demos for its style (or, with ``windows="rest"``, steps ranked by the
    path that remains from them: :mod:`scdp.scoring.rest`), base frozen."""
    if part in STYLES:  # the style alone names the predictor of ``preset.style``
        part = style_part(part)
    if part_design(part) is None:
        raise ScdpError("part", f"unknown style part {part!r}")
    style = part_style(part)
    section = preset.style_section(part)
    task.check_task(dataset.task)
    job = _record(record, task, preset, part, dataset, base_dir, encoder_dir)
    device = resolve_device(device)
    base = load_diffusion(base_dir, task, planning=PlanningOptions(device=str(device))).requires_grad_(False).eval()
    encoder = load_encoder(encoder_dir, task, device).requires_grad_(False).eval()
    if dataset.goals.shape[1] != encoder.config.n_goals:
        raise ScdpError("--data", f"demos have {dataset.goals.shape[1]} goals per scene, the encoder {encoder.config.n_goals}")
    predictor = build_style(preset, base, encoder, part)
    if section.windows == "rest":  # every demo, the windows whose remaining path has the style (scdp.scoring.rest)
        subset = dataset
        data = WindowData(dataset, base.config.n_obs_steps, base.config.horizon, task)
        data.keep(top_by_progress(rest_scores(dataset, style), data.progress.numpy(), preset.data.style_fraction))
    else:
        score = section.efficient_score if style == "efficient" else section.legible_score
        subset = style_subset(dataset, style, preset.data.style_fraction, references=references, score=score)
        data = WindowData(subset, base.config.n_obs_steps, base.config.horizon, task)
    data.keep_early(section.early_windows)
    first_styled = predictor.config.first_styled_step(base.config.num_train_timesteps)

    def loss(batch: TrainBatch, generator):
        with torch.no_grad():
            x = predictor_input(predictor.config, encoder, base.normalizer.goal, batch.goals, batch.target,
                                batch.obs_position[:, -1])
        return base.loss(batch, film=predictor(x), generator=generator, x0_weight_cap=section.x0_weight_cap,
                         min_step=first_styled)

    save = _saver(out, part, task, preset, job, predictor.config, extra={"subset_demos": subset.num_episodes, "style": style,
                                                                           "arbitration": section.arbitration,
                                                                           "windows": len(data)})
    result = train(predictor, loss, data, section.train, out, save, resume=resume, desc=f"{task.name} {part}",
                   progress=progress, job=job, device=device)
    return predictor, result


def train_student(task: Task, dataset, preset: Preset, base_dir, encoder_dir, out, *, resume=False, progress=True,
                  device="cpu", record: dict | None = None):
    """The few-step student (:mod:`scdp.training.distill`) on every demo window the base learnt from:
    a copy of the base in ``base_dir``, fine-tuned to reach in ``preset.student.steps`` DDIM steps the
    chunk the frozen base reaches in ``teacher_steps``, with the films of the two style predictors
    beside the base and the encoder in ``encoder_dir``."""
    task.check_task(dataset.task)
    job = _record(record, task, preset, STUDENT_PART, dataset, base_dir, encoder_dir)
    section, device = preset.student, resolve_device(device)
    planning = PlanningOptions(sampler=TEACHER_SAMPLER, steps=section.teacher_steps, device=str(device))
    teacher = load_method("scdp_blend", Path(base_dir).parent, task, planning, encoder_dir=encoder_dir)
    teacher.base.requires_grad_(False).eval()
    n = preset.data.base_demos
    if n is not None and n < dataset.num_episodes:
        dataset = dataset.subset(range(n))
    data = WindowData(dataset, teacher.base.config.n_obs_steps, teacher.base.config.horizon, task)
    config = DiffusionConfig.from_dict({**teacher.base.config.to_dict(), "sampler": TEACHER_SAMPLER, "num_inference_steps": section.steps})
    student = DiffusionPolicy(config, teacher.base.normalizer, task.task_space)
    student.unet.load_state_dict(teacher.base.unet.state_dict())  # the same network: the films mean the same
    distillation = Distillation(teacher, student.to(device), section.styled, section.step_weight)
    extra = {"demos": dataset.num_episodes, "init": checkpoint.read_meta(base_dir, "base").get("weights_sha256"),
             "distilled": {"teacher_sampler": TEACHER_SAMPLER, "teacher_steps": section.teacher_steps, "styled": section.styled,
                           "step_weight": section.step_weight}}
    save = _saver(out, STUDENT_PART, task, preset, job, student.config, student.normalizer, extra)
    result = train(student, distillation.loss, data, section.train, out, save, resume=resume,
                   desc=f"{task.name} {STUDENT_PART}", progress=progress, job=job, device=device)
    return student, result


def train_part(task: Task, preset: Preset, part: str, out, *, dataset=None, base_dir=None, encoder_dir=None, resume=False,
               progress=True, device="cpu", record: dict | None = None):
    """Train ``part`` (``encoder``, ``base``, ``ld``, a ``style_*`` predictor or the ``student``) into ``out``: the one
    dispatch behind ``scdp train`` and ``scdp reproduce``. ``dataset``: the demonstrations (every
    part but the encoder); ``base_dir``, ``encoder_dir``: the parts it starts from. Returns
    ``(module, TrainResult)``."""
    common = {"resume": resume, "progress": progress, "device": device, "record": record}
    if part == "encoder":
        return train_encoder(task, preset, out, **common)
    if dataset is None:
        raise ScdpError("--data", f"training {part} needs demonstrations")
    if part in ("base", "ld"):
        return train_diffusion(task, dataset, preset, out, ld=part == "ld", base_dir=base_dir, **common)
    if part == STUDENT_PART:
        return train_student(task, dataset, preset, base_dir, encoder_dir, out, **common)
    return train_style(task, dataset, part, preset, base_dir, encoder_dir, out, **common)


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
