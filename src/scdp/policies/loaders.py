"""Models and planners from checkpoint folders (see :mod:`scdp.policies.checkpoint`).

:func:`load_method` is the one factory: ``dp``, ``ld`` or ``scdp`` (with a style mode) from a
folder holding ``base/``, ``ld/``, ``encoder/``, ``style_legible/`` and ``style_efficient/``.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

from scdp.config import DiffusionConfig, EncoderConfig, GuidanceConfig, StyleConfig
from scdp.data.normalizer import Normalizer
from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError
from scdp.keys import ALL_PLANNERS, PAPER_METHOD, SCDP_METHODS, STYLE_MODES, STYLES
from scdp.messages import preview
from scdp.models.scene_encoder import SceneAutoencoder
from scdp.models.style_predictor import StylePredictor
from scdp.policies.checkpoint import load_weights, read_meta
from scdp.policies.diffusion import DiffusionPolicy
from scdp.policies.legibility_diffuser import LegibilityDiffuser
from scdp.policies.scdp import StyleConditionedPolicy


def planner_name(spec: str) -> str:
    """The one name of the planner a ``method_spec`` names: ``scdp:legible`` is ``scdp_legible``,
    ``scdp:auto`` is ``scdp``; a plain name is itself."""
    method, _, style = spec.partition(":")
    if method == "scdp" and style:
        return next(name for name, mode in SCDP_METHODS.items() if mode == style)
    return method


def planner_style(method: str, style: str | None, field: str = "--style") -> str | None:
    """The style ``load_method`` takes for ``method`` when ``style`` was asked for (``None``: not given).

    Only ``scdp`` has a style choice (default ``auto``). ``scdp_<style>`` fixes its style: asking for
    that same one is accepted, another is refused. A style asked of a method without styles (dp, ld,
    ld_paper, scdp_paper) is refused too: ignoring it would plan something other than what was asked.
    Returns ``None`` for every method but ``scdp``.
    """
    if style is None:
        return "auto" if method == "scdp" else None
    if style not in STYLE_MODES:
        raise ScdpError(field, f"unknown style {preview(style)}; choose from {', '.join(STYLE_MODES)}")
    if method == "scdp":
        return style
    if method in SCDP_METHODS:
        if SCDP_METHODS[method] == style:
            return None
        raise ScdpError(field, f"{method} fixes the style {SCDP_METHODS[method]!r}, not {style!r} (scdp takes any style)")
    raise ScdpError(field, f"{preview(method)} has no style choice; a style goes with scdp")


def load_diffusion(folder, task, part: str = "base", sampler: str | None = None, steps: int | None = None,
                   device="cpu") -> DiffusionPolicy:
    """A trained base (or LD's base with ``part="ld"``) on ``device``; ``sampler``/``steps`` replace
    the saved planning-time sampler and its step count (no retraining: the net predicts ε at any step)."""
    folder = Path(folder)
    meta = read_meta(folder, part, task)
    with _in_checkpoint(part):
        config = planning_config(meta["config"], sampler, steps)
        dims = {"state": config.state_dim, "action": config.state_dim, "goal": config.goal_dim, "offset": config.goal_dim}
        normalizer = Normalizer.from_dict(meta.get("normalizer"), dims)
    return load_weights(DiffusionPolicy(config, normalizer, task.task_space), folder, part, meta).to(device)


@contextmanager
def _in_checkpoint(part: str):
    """Name the checkpoint a bad saved config belongs to: ``checkpoints/<part>: config.json <field>: ...``
    (a bad ``--sampler`` or ``--steps`` keeps its own field)."""
    try:
        yield
    except ScdpError as err:
        if err.field.startswith("--"):
            raise
        raise ScdpError(f"checkpoints/{part}", f"config.json {err.field}: {err.message}") from None


def planning_config(saved: dict, sampler: str | None = None, steps: int | None = None) -> DiffusionConfig:
    """A saved base's :class:`DiffusionConfig` with its planning-time ``sampler`` and ``steps``
    replaced where given, validated; a bad replacement names ``--sampler`` or ``--steps``."""
    chosen = {k: v for k, v in (("sampler", sampler), ("num_inference_steps", steps)) if v is not None}
    try:
        return DiffusionConfig.from_dict({**saved, **chosen})
    except ScdpError as err:
        if err.field == "num_inference_steps" and steps is not None:
            raise ScdpError("--steps", f"must be 1..{saved.get('num_train_timesteps')} (the checkpoint's training "
                                       f"timesteps), got {steps}") from None
        if err.field == "sampler" and sampler is not None:
            raise ScdpError("--sampler", err.message) from None
        raise


def load_encoder(folder, task, device="cpu") -> SceneAutoencoder:
    folder = Path(folder)
    meta = read_meta(folder, "encoder", task)
    with _in_checkpoint("encoder"):
        config = EncoderConfig.from_dict(meta["config"])
    return load_weights(SceneAutoencoder(config), folder, "encoder", meta).to(device)


def load_style(folder, task, style: str, device="cpu", part: str | None = None) -> StylePredictor:
    """A trained style predictor (part ``style_<style>``, or ``part`` where given, e.g. ``style_paper_legible``)."""
    folder = Path(folder)
    part = part or f"style_{style}"
    meta = read_meta(folder, part, task)
    with _in_checkpoint(part):
        config = StyleConfig.from_dict(meta["config"])
    return load_weights(StylePredictor(config), folder, part, meta).to(device)


def load_ld(folder, task, guidance: GuidanceConfig | None = None, sampler: str | None = None,
            steps: int | None = None, device="cpu") -> LegibilityDiffuser:
    """Legibility Diffuser with the guidance saved in its checkpoint (or ``guidance``, if given)."""
    folder = Path(folder)
    saved = read_meta(folder, "ld", task).get("guidance")
    if guidance is None and saved is not None:
        with _in_checkpoint("ld"):
            try:
                guidance = GuidanceConfig.from_dict(saved)
            except ScdpError as exc:
                raise ScdpError("guidance", exc.message if exc.field == "guidance" else str(exc)) from None
    guidance = guidance or GuidanceConfig()
    return LegibilityDiffuser(load_diffusion(folder, task, "ld", sampler, steps, device), guidance)


def load_method(checkpoints, task, method: str, style: str | None = None, encoder_dir=None, *, film_scale: float = 1.0,
                style_guidance: float = 0.0, arbitration: str | None = None, guidance: GuidanceConfig | None = None,
                sampler: str | None = None, steps: int | None = None, device="cpu"):
    """A :class:`~scdp.policies.base.Planner` for ``method`` from a checkpoints folder.

    ``method`` is one of :data:`scdp.keys.ALL_PLANNERS`: ``ld_paper`` uses the authors' guidance (every step),
    ``ld`` the guidance saved in its checkpoint (or ``guidance``); ``scdp`` with ``style`` (auto, blend, legible,
    efficient, none) is the same as the matching ``scdp_<style>`` name. The scene encoder is
    ``checkpoints/encoder`` unless ``encoder_dir`` names another folder (the per-layout model
    sets share their task's encoder). ``sampler`` and ``steps`` replace the checkpoints' planning-time
    sampler (``ddpm``, ``ddim``, ``dpmsolver``) and step count. ``arbitration=None`` takes the rule
    saved with the style predictors (``ellipse`` for checkpoints that saved none). The networks
    are placed on ``device`` (a ``torch.device`` or a name, see :func:`scdp.devices.resolve`).
    """
    device = resolve_device(device)
    root = Path(checkpoints)
    if not root.is_dir():
        raise ScdpError("--checkpoints", f"{root} is not a folder")
    if method == "dp":
        return load_diffusion(root / "base", task, sampler=sampler, steps=steps, device=device)
    if method == "ld":
        return load_ld(root / "ld", task, guidance, sampler, steps, device)
    if method == "ld_paper":
        return load_ld(root / "ld", task, GuidanceConfig(), sampler, steps, device)
    if method in SCDP_METHODS or method == PAPER_METHOD:
        style = style or SCDP_METHODS.get(method, "auto")
        prefix = "style_paper_" if method == PAPER_METHOD else "style_"  # scdp_paper: the paper-design predictors
        base = load_diffusion(root / "base", task, sampler=sampler, steps=steps, device=device)
        encoder = load_encoder(root / "encoder" if encoder_dir is None else encoder_dir, task, device)
        both = style in ("auto", "blend") or (style_guidance > 0 and style != "none")  # guidance contrasts the two
        wanted = list(STYLES) if both else [s for s in (style,) if s != "none"]
        predictors = {s: load_style(root / f"{prefix}{s}", task, s, device, part=f"{prefix}{s}") for s in wanted}
        if arbitration is None:
            first = f"{prefix}legible"
            saved = read_meta(root / first, first, task) if (root / first).is_dir() else {}
            arbitration = saved.get("arbitration", "ellipse")
        for name, pred in predictors.items():
            want = base.unet.film_width(pred.config.film_blocks)
            if pred.config.film_width != want:
                raise ScdpError(f"checkpoints/{prefix}{name}", f"gives a film of width {pred.config.film_width} for "
                                f"{pred.config.film_blocks!r} blocks, the base needs {want}")
            if pred.config.context_dim != encoder.config.context_dim:
                raise ScdpError(f"checkpoints/{prefix}{name}", f"expects context {pred.config.context_dim}, the encoder gives {encoder.config.context_dim}")
        if len({p.config.film_blocks for p in predictors.values()}) > 1:
            raise ScdpError("checkpoints", "the two style predictors act on different blocks (film_blocks); retrain one")
        return StyleConditionedPolicy(base, encoder, predictors, task, style=style, film_scale=film_scale,
                                      style_guidance=style_guidance, arbitration=arbitration)
    raise ScdpError("--methods", f"unknown method {method!r} (choose from {', '.join(ALL_PLANNERS)})")


def network_parameters(planner) -> int:
    """Parameters of the denoising network a planner samples from (SCDP's and LD's base, or the
    policy's own), e.g. to size the thread pool (:func:`scdp.threads.use_for_planning`)."""
    policy = next((p for p in (getattr(planner, "base", None), getattr(planner, "policy", None)) if p is not None), planner)
    return sum(p.numel() for p in policy.unet.parameters())


def chunk_steps(planner) -> int:
    """Actions per chunk (``n_action_steps``) of any planner: SCDP's and LD's base, or the policy's own."""
    policy = next((p for p in (getattr(planner, "base", None), getattr(planner, "policy", None)) if p is not None), planner)
    return policy.config.n_action_steps
