"""Models and planners from checkpoint folders (see :mod:`scdp.policies.checkpoint`).

:func:`load_method` is the one factory: a :class:`~scdp.config.PlannerSpec` (``dp``, ``ld``,
``ld_paper``, ``scdp`` with a style mode, ``scdp_paper``, or a planner registered in :mod:`scdp.planners`)
from a folder holding ``base/``, ``ld/``, ``encoder/``, ``style_legible/`` and ``style_efficient/``, planned
as the :class:`~scdp.config.PlanningOptions` ask (sampler, steps, warm start, device, runtime, profile). A
planner's registration says how it loads: its own ``load``, or its family's loader
(:data:`FAMILY_LOADERS`). Every network scdp's planners run is built here, in :func:`load_diffusion`,
:func:`load_encoder` and :func:`load_style`.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

from scdp import planners
from scdp.config import DiffusionConfig, EncoderConfig, GuidanceConfig, PlannerSpec, PlanningOptions, StyleConfig
from scdp.data.normalizer import Normalizer
from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError
from scdp.keys import STYLES, style_part, styles_needed
from scdp.models.scene_encoder import SceneAutoencoder
from scdp.models.style_predictor import StylePredictor
from scdp.policies.checkpoint import ONNX_META, load_weights, read_meta
from scdp.policies.diffusion import DiffusionPolicy
from scdp.policies.exported import AutoDenoiser, OnnxDenoiser
from scdp.policies.legibility_diffuser import LegibilityDiffuser
from scdp.policies.placement import place
from scdp.policies.scdp import StyleConditionedPolicy
from scdp.tasks import Task

DEFAULT_PLANNING = PlanningOptions()


def load_diffusion(folder, task: Task, part: str = "base", planning: PlanningOptions = DEFAULT_PLANNING) -> DiffusionPolicy:
    """A trained base (or LD's base with ``part="ld"``) on ``planning.device``; ``planning.sampler`` and
    ``planning.steps`` replace the saved planning-time sampler and its step count (no retraining: the
    net predicts ε at any step). With ``planning.runtime == "onnx"`` its denoiser is the graph
    ``scdp export`` wrote (:class:`~scdp.policies.exported.OnnxDenoiser`), on the CPU; with ``auto``
    that graph at small batches where it was exported, and the torch network where it was not. Unset
    options come from ``planning.profile`` as for the planner that runs the part (DP's for the base, LD's
    for ``part="ld"``, the student's own sampler for ``part="student"``: :func:`scdp.planners.denoiser_method`)."""
    folder = Path(folder)
    planning = planning.for_method(planners.denoiser_method(part))  # unset options from the profile
    meta = read_meta(folder, part, task)
    with _in_checkpoint(part):
        config = planning_config(meta["config"], planning.sampler, planning.steps)
        dims = {"state": config.state_dim, "action": config.state_dim, "goal": config.goal_dim, "offset": config.goal_dim}
        normalizer = Normalizer.from_dict(meta.get("normalizer"), dims)
    policy = load_weights(DiffusionPolicy(config, normalizer, task.task_space), folder, part, meta)
    policy.use_warm_start(planning.warm_skip)  # refused, on --warm-skip, unless below the sampler's steps
    device = resolve_device(planning.device)
    where = place(planning.runtime, device.type, planning.cuda_graphs == "on", (folder / ONNX_META).is_file())
    policy.place(where)
    if where.denoiser == "onnx":  # the exported graph in place of the torch network (scdp export)
        policy.unet = OnnxDenoiser(folder)
        return policy
    if where.denoiser == "auto":
        policy.unet = AutoDenoiser(policy.unet, folder)  # the graph below AUTO_BATCH scenes per call
        return policy
    return policy.to(device)  # the torch network on the device


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


def load_encoder(folder, task: Task, device="cpu") -> SceneAutoencoder:
    folder = Path(folder)
    meta = read_meta(folder, "encoder", task)
    with _in_checkpoint("encoder"):
        config = EncoderConfig.from_dict(meta["config"])
    return load_weights(SceneAutoencoder(config), folder, "encoder", meta).to(device)


def load_style(folder, task: Task, style: str, device="cpu", part: str | None = None) -> StylePredictor:
    """A trained style predictor (part ``style_<style>``, or ``part`` where given, e.g. ``style_paper_legible``)."""
    folder = Path(folder)
    part = part or style_part(style)
    meta = read_meta(folder, part, task)
    with _in_checkpoint(part):
        config = StyleConfig.from_dict(meta["config"])
    return load_weights(StylePredictor(config), folder, part, meta).to(device)


def load_ld(folder, task: Task, guidance: GuidanceConfig | None = None,
            planning: PlanningOptions = DEFAULT_PLANNING) -> LegibilityDiffuser:
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
    return LegibilityDiffuser(load_diffusion(folder, task, "ld", planning), guidance)  # its unset options: LD's


def load_method(spec: PlannerSpec | str, checkpoints, task: Task, planning: PlanningOptions = DEFAULT_PLANNING, *,
                encoder_dir=None, film_scale: float = 1.0, style_guidance: float = 0.0, arbitration: str | None = None,
                guidance: GuidanceConfig | None = None):
    """A :class:`~scdp.policies.base.Planner` for ``spec`` (a :class:`~scdp.config.PlannerSpec`, or a
    name such as ``"scdp_legible"`` or ``"scdp:legible"``) from a checkpoints folder, as ``planning`` asks.

    ``ld_paper`` uses the authors' guidance (every step), ``ld`` the guidance saved in its checkpoint
    (or ``guidance``). The scene encoder is ``checkpoints/encoder`` unless ``encoder_dir`` names
    another folder (the per-layout model sets share their task's encoder). ``arbitration=None``
    takes the rule saved with the style predictors (``ellipse`` for checkpoints that saved none);
    ``film_scale`` and ``style_guidance`` are SCDP's ablation knobs (1 and 0: the method as trained).
    """
    spec = as_spec(spec)
    resolve_device(planning.device)  # a device this machine lacks is refused before anything loads
    planning = planning.for_method(spec.method)  # the options left unset, from the profile
    root = Path(checkpoints)
    if not root.is_dir():
        raise ScdpError("--checkpoints", f"{root} is not a folder")
    kind = spec.kind
    load = kind.load or FAMILY_LOADERS[kind.family]
    return load(spec, root, task, planning, encoder_dir=encoder_dir, film_scale=film_scale,
                style_guidance=style_guidance, arbitration=arbitration, guidance=guidance)


def _load_dp(spec: PlannerSpec, root: Path, task: Task, planning: PlanningOptions, **_) -> DiffusionPolicy:
    return load_diffusion(root / spec.kind.denoiser, task, spec.kind.denoiser, planning)


def _load_ld(spec: PlannerSpec, root: Path, task: Task, planning: PlanningOptions, *, guidance=None, **_):
    return load_ld(root / spec.kind.denoiser, task, GuidanceConfig() if spec.kind.authors else guidance, planning)


def _load_scdp(spec: PlannerSpec, root: Path, task: Task, planning: PlanningOptions, *, encoder_dir=None,
               film_scale: float = 1.0, style_guidance: float = 0.0, arbitration: str | None = None, **_):
    """SCDP of the spec's design (its predictors), style mode ``spec.style`` (``scdp_paper``: arbitrated per chunk)."""
    device = resolve_device(planning.device)
    style = spec.style or "auto"
    part_of = {s: style_part(s, spec.kind.design) for s in STYLES}
    base = load_diffusion(root / spec.kind.denoiser, task, spec.kind.denoiser, planning)
    encoder = load_encoder(root / "encoder" if encoder_dir is None else encoder_dir, task, device)
    both = style_guidance > 0 and style != "none"  # guidance contrasts the two styles
    wanted = list(STYLES) if both else [s for s in STYLES if s in styles_needed(style)]
    predictors = {s: load_style(root / part_of[s], task, s, device, part=part_of[s]) for s in wanted}
    if arbitration is None:
        first = part_of["legible"]
        saved = read_meta(root / first, first, task) if (root / first).is_dir() else {}
        arbitration = saved.get("arbitration", "ellipse")
    _check_fits(base, encoder, predictors, part_of)
    return StyleConditionedPolicy(base, encoder, predictors, task, style=style, film_scale=film_scale,
                                  style_guidance=style_guidance, arbitration=arbitration)


def _check_fits(base: DiffusionPolicy, encoder: SceneAutoencoder, predictors: dict, part_of: dict) -> None:
    """The style predictors give films the base takes, read the encoder's context, and act on one set of blocks."""
    for name, pred in predictors.items():
        want = base.unet.film_width(pred.config.film_blocks)
        if pred.config.film_width != want:
            raise ScdpError(f"checkpoints/{part_of[name]}", f"gives a film of width {pred.config.film_width} for "
                            f"{pred.config.film_blocks!r} blocks, the base needs {want}")
        if pred.config.context_dim != encoder.config.context_dim:
            raise ScdpError(f"checkpoints/{part_of[name]}",
                            f"expects context {pred.config.context_dim}, the encoder gives {encoder.config.context_dim}")
    if len({p.config.film_blocks for p in predictors.values()}) > 1:
        raise ScdpError("checkpoints", "the two style predictors act on different blocks (film_blocks); retrain one")


# How scdp builds each family's planner; a registered planner with its own ``load`` needs none (scdp.planners).
FAMILY_LOADERS = {"dp": _load_dp, "ld": _load_ld, "scdp": _load_scdp}


def as_spec(spec: PlannerSpec | str) -> PlannerSpec:
    """A planner name as its spec (a spec as itself)."""
    return spec if isinstance(spec, PlannerSpec) else PlannerSpec.parse(spec, field="method")


def method_parts(spec: PlannerSpec | str) -> tuple[str, ...]:
    """The checkpoint parts :func:`load_method` reads for ``spec`` (:attr:`PlannerSpec.parts`)."""
    return as_spec(spec).parts


def denoiser_part(spec: PlannerSpec | str) -> str | None:
    """The checkpoint part holding ``spec``'s denoiser (``ld`` for Legibility Diffuser, ``base`` for
    DP and SCDP), None for a planner without one."""
    return as_spec(spec).kind.denoiser


def without_graph(checkpoints, methods, planning: PlanningOptions) -> dict[str, str]:
    """``{method: its denoiser part}`` for each of ``methods`` that ``planning`` runs with ``--runtime
    onnx`` but whose denoiser has no exported graph (``scdp export`` writes them)."""
    root = Path(checkpoints)
    return {m: denoiser_part(m) for m in methods if planning.for_method(as_spec(m).method).runtime == "onnx"
            and denoiser_part(m) is not None and not (root / denoiser_part(m) / ONNX_META).is_file()}


def loaded_parts(checkpoints, methods, task: Task, planning: PlanningOptions = DEFAULT_PLANNING) -> dict[str, dict]:
    """What the planners of ``methods`` run, for a client or a record: each part's weights SHA-256
    (checked against the file whenever the part loads) and the runtime that runs it (``onnx`` for a
    denoiser exported and planned with ``--runtime onnx``, else ``torch``)."""
    root = Path(checkpoints)
    parts = dict.fromkeys(p for m in methods for p in method_parts(m))

    def runtime(part: str) -> str:  # the first method reading the part decides; a graph only for a denoiser
        spec = next(as_spec(m) for m in methods if part in method_parts(m))
        chosen = planning.for_method(spec.method).runtime
        exported = (root / part / ONNX_META).is_file()
        if chosen is None or not exported or part != spec.kind.denoiser:
            return "torch"
        placed = place(chosen, resolve_device(planning.device).type, True, exported)  # the one placement decision
        return "onnx" if placed.denoiser in ("onnx", "auto") else "torch"

    return {p: {"weights_sha256": read_meta(root / p, p, task).get("weights_sha256"), "runtime": runtime(p)} for p in parts}
