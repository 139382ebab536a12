"""What to plan with, and how: :class:`PlannerSpec` and :class:`PlanningOptions`.

Every entry point that plans (``scdp plan``, ``evaluate``, ``serve``, ``deploy``, ``reproduce``
and the Python API) names a planner and a few planning-time options. Both are values made once,
where the user gave them, and handed whole to :func:`scdp.policies.loaders.load_method`::

    spec = PlannerSpec.parse("scdp:legible")          # or PlannerSpec.of("scdp", style="legible")
    planning = PlanningOptions(sampler="ddim", steps=10, device="cpu")
    planner = load_method(spec, "runs/cpu/navigation/checkpoints", task, planning)

A new planning-time option (for example the ONNX runtime) is one field of :class:`PlanningOptions`
(its flag is in the field's metadata) and one branch in the loader that builds the network
(:func:`scdp.policies.loaders.load_diffusion`); no command handler in between changes.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

from scdp.errors import ScdpError
from scdp.keys import ALL_PLANNERS, RUNTIMES, SAMPLERS, SCDP_METHODS, STYLE_MODES
from scdp.messages import preview
from scdp.sections import Section

SCDP = "scdp"  # the one method that takes a style mode; scdp_<mode> fixes one


@dataclass(frozen=True)
class PlannerSpec:
    """A planner by name: ``method`` is ``dp``, ``ld``, ``ld_paper``, ``scdp`` or ``scdp_paper``, and
    ``style`` the style mode of ``scdp`` (``None`` for every other method).

    The SCDP family is folded into ``scdp`` with its mode, so ``scdp_legible``, ``scdp:legible`` and
    ``scdp`` with ``--style legible`` are one spec (equal and hashing alike); ``label`` keeps the
    name as the user wrote it, for records and printed tables, and takes no part in equality.
    """

    method: str
    style: str | None = None
    label: str = field(default="", compare=False)

    @classmethod
    def parse(cls, text: str, field: str = "--methods") -> PlannerSpec:
        """``dp``, ``scdp_blend`` or ``scdp:legible``, checked; a bad one is refused on ``field``."""
        method, colon, style = text.partition(":")
        if method not in ALL_PLANNERS:
            raise ScdpError(field, f"unknown method {preview(method)}; choose from {', '.join(ALL_PLANNERS)}")
        if colon and (method != SCDP or style not in STYLE_MODES):
            raise ScdpError(field, f"{preview(text)}: only scdp takes a style, one of {', '.join(STYLE_MODES)}")
        return cls._canonical(method, style or None, label=text)

    @classmethod
    def of(cls, method: str, style: str | None = None, *, field: str = "--style",
           method_field: str = "--method") -> PlannerSpec:
        """A method name and a separately asked style (``None``: not asked), checked.

        Only ``scdp`` has a style choice (default ``auto``). ``scdp_<style>`` fixes its style: asking
        for that same one is accepted, another is refused. A style asked of a method without styles
        (dp, ld, ld_paper, scdp_paper) is refused too: ignoring it would plan something other than
        what was asked.
        """
        if method not in ALL_PLANNERS:
            raise ScdpError(method_field, f"unknown method {preview(method)}; choose from {', '.join(ALL_PLANNERS)}")
        if style is not None:
            if style not in STYLE_MODES:
                raise ScdpError(field, f"unknown style {preview(style)}; choose from {', '.join(STYLE_MODES)}")
            if method in SCDP_METHODS and method != SCDP and SCDP_METHODS[method] != style:
                raise ScdpError(field, f"{method} fixes the style {SCDP_METHODS[method]!r}, not {style!r} "
                                       "(scdp takes any style)")
            if method not in SCDP_METHODS:
                raise ScdpError(field, f"{preview(method)} has no style choice; a style goes with scdp")
        return cls._canonical(method, style, label=method)

    @classmethod
    def _canonical(cls, method: str, style: str | None, label: str) -> PlannerSpec:
        if method in SCDP_METHODS:  # scdp_<mode> is scdp with that mode; plain scdp chooses per chunk
            return cls(SCDP, style or SCDP_METHODS[method], label)
        return cls(method, None, label)

    @property
    def has_encoder(self) -> bool:
        """Does this planner read the scene through the scene encoder (SCDP and the paper's design)?"""
        return self.method in (SCDP, "scdp_paper")


DEVICE_FLAG = {"default": "auto", "metavar": "DEVICE",
               "help": "where the networks run: auto (a CUDA GPU when torch sees one, else the CPU; default), cpu, "
                       "cuda or cuda:K. Random draws come from CPU generators, so a seed draws alike on every device"}


@dataclass(frozen=True)
class PlanningOptions(Section):
    """Planning-time options, none of which changes what was trained.

    ``sampler`` (``ddpm``, ``ddim``, ``dpmsolver``) and ``steps`` replace the sampler saved with the
    checkpoints and its step count (``None``: the saved one; checked against the checkpoint when it
    loads, naming ``--sampler`` or ``--steps``). ``device`` is where the networks run: ``auto``,
    ``cpu``, ``cuda`` or ``cuda:K`` (:func:`scdp.devices.resolve`). ``runtime`` is what runs the
    denoiser: ``torch``, or ``onnx`` (:mod:`scdp.policies.exported`, on the CPU).

    Each field's ``metadata`` is its command-line flag (argparse keywords), so a new option is one
    field here: :func:`scdp.cli.parser_common.planning_args` adds the flag and :meth:`from_args` reads it back.
    """

    sampler: str | None = field(default=None, metadata={
        "choices": list(SAMPLERS),
        "help": "planning-time sampler, replacing the one saved with the checkpoints (the cpu preset's: ddpm). ddim "
                "and dpmsolver are deterministic; on the cpu preset they lengthen Block Reach's paths "
                "(results/benchmarks/sampler_sweep_*.md). No retraining is needed"})
    steps: int | None = field(default=None, metadata={
        "type": int,
        "help": "denoising steps of the sampler (default: the checkpoints'; cpu preset 20, the fewest that keep "
                "success and T against 100)"})
    warm_skip: int = field(default=0, metadata={
        "type": int, "default": 0,
        "help": "warm start: each chunk starts from the previous chunk's plan, shifted and re-noised to this step "
                "of the sampler's steps, so it costs steps - warm_skip network calls (0, the default: from pure "
                "noise). A chunk still starts cold at an episode's start, after a style change, or when the robot "
                "is off its plan. No retraining is needed"})
    device: str = field(default="cpu", metadata=DEVICE_FLAG)
    runtime: str = field(default="torch", metadata={
        "choices": list(RUNTIMES), "default": "torch",
        "help": "what runs the denoiser: torch (default) or onnx, the graph scdp export wrote beside each diffusion "
                "checkpoint, run by ONNX Runtime on the CPU. The sampling loop, the style predictors and the encoder "
                "stay in torch; the same seed draws the same noise. onnx is faster at batch 1 (plan, serve, deploy), "
                "torch at large batches (evaluate); auto runs the graph below 8 scenes per call and torch from 8 on"})

    def _check(self):
        if not isinstance(self.warm_skip, int) or self.warm_skip < 0:
            raise ScdpError("--warm-skip", f"must be an integer >= 0, got {preview(str(self.warm_skip))}")
        if self.runtime not in RUNTIMES:
            raise ScdpError("--runtime", f"one of {', '.join(RUNTIMES)}, got {preview(str(self.runtime))}")
        if self.runtime in ("onnx", "auto") and self.device not in ("cpu", "auto"):
            raise ScdpError("--runtime", f"{self.runtime} runs on the CPU (ONNX Runtime); pass --device cpu, not "
                                         f"{preview(str(self.device))}")

    @classmethod
    def flags(cls) -> list[tuple[str, dict]]:
        """(``--flag``, argparse keywords) of each field, in order."""
        return [("--" + f.name.replace("_", "-"), dict(f.metadata)) for f in fields(cls)]

    @classmethod
    def from_args(cls, args) -> PlanningOptions:
        """The options of a parsed command line (one attribute per field, as :meth:`flags` adds them)."""
        return cls(**{f.name: getattr(args, f.name) for f in fields(cls)})
