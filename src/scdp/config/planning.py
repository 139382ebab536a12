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

from dataclasses import dataclass, field, fields, replace

from scdp import planners
from scdp.errors import ScdpError
from scdp.keys import RUNTIMES, SAMPLERS, STYLE_MODES
from scdp.messages import preview
from scdp.sections import Section


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
        registered = planners.kind(method, field)
        if colon and (not registered.takes_style or style not in STYLE_MODES):
            raise ScdpError(field, f"{preview(text)}: only {' and '.join(planners.styled())} take a style, one of "
                                   f"{', '.join(STYLE_MODES)}")
        return cls._canonical(registered, style or None, label=text)

    @classmethod
    def of(cls, method: str, style: str | None = None, *, field: str = "--style",
           method_field: str = "--method") -> PlannerSpec:
        """A method name and a separately asked style (``None``: not asked), checked.

        Only ``scdp`` (and ``scdp_student``) has a style choice (default ``auto``). ``scdp_<style>`` fixes its style: asking
        for that same one is accepted, another is refused. A style asked of a method without styles
        (dp, ld, ld_paper, scdp_paper) is refused too: ignoring it would plan something other than
        what was asked.
        """
        registered = planners.kind(method, method_field)
        if style is not None:
            if style not in STYLE_MODES:
                raise ScdpError(field, f"unknown style {preview(style)}; choose from {', '.join(STYLE_MODES)}")
            if registered.style is not None and registered.style != style:
                raise ScdpError(field, f"{method} fixes the style {registered.style!r}, not {style!r} "
                                       "(scdp takes any style)")
            if registered.style is None and not registered.takes_style:
                raise ScdpError(field, f"{preview(method)} has no style choice; a style goes with scdp")
        return cls._canonical(registered, style, label=method)

    @classmethod
    def _canonical(cls, registered: planners.PlannerKind, style: str | None, label: str) -> PlannerSpec:
        if registered.takes_style:  # scdp, scdp_student: their mode, auto by default
            return cls(registered.name, style or "auto", label)
        if registered.style is not None:  # scdp_<mode> is scdp with that mode
            return cls(planners.SCDP, registered.style, label)
        return cls(registered.name, None, label)

    @property
    def kind(self) -> planners.PlannerKind:
        """This planner's registration (:mod:`scdp.planners`): family, parts, loader."""
        return planners.kind(self.method)

    @property
    def family(self) -> str:
        """``dp``, ``ld`` (tuned or the authors' guidance), ``scdp`` (the paper's design too), or a
        registered planner's own family."""
        return self.kind.family

    @property
    def parts(self) -> tuple[str, ...]:
        """The checkpoint parts this planner reads (every style's predictor of its design for SCDP)."""
        return self.kind.parts

    @property
    def has_encoder(self) -> bool:
        """Does this planner read the scene through the scene encoder (SCDP and the paper's design)?"""
        return "encoder" in self.kind.parts


DEVICE_FLAG = {"default": "auto", "metavar": "DEVICE",
               "help": "where the networks run: auto (a CUDA GPU when torch sees one, else the CPU; default), cpu, "
                       "cuda or cuda:K. Random draws come from CPU generators, so a seed draws alike on every device"}


PROFILES = ("trained", "realtime")
TRAINED = {"warm_skip": 0, "runtime": "torch"}  # sampler and steps None: the checkpoints' own
REALTIME = {"sampler": "ddpm", "steps": 8, "warm_skip": 4, "runtime": "auto"}  # results/benchmarks/realtime_gate.md
AUTO_BATCH = 8  # runtime "auto": ONNX Runtime below this many scenes per call, torch from it on
_FAST = f"{REALTIME['sampler'].upper()}-{REALTIME['steps']} warm-started at step {REALTIME['warm_skip']}"  # as help text says it
ENTRY_PROFILES = {"plan": "realtime", "serve": "realtime", "deploy": "realtime", "control_loop": "realtime",
                  "evaluate": "trained", "reproduce": "trained"}  # every entry point's default, read from here only


@dataclass(frozen=True)
class PlanningOptions(Section):
    """Planning-time options, none of which changes what was trained.

    ``sampler`` (``ddpm``, ``ddim``, ``dpmsolver``) and ``steps`` replace the sampler saved with the
    checkpoints and its step count (checked against the checkpoint when it loads, naming ``--sampler``
    or ``--steps``). ``device`` is where the networks run: ``auto``, ``cpu``, ``cuda`` or ``cuda:K``
    (:func:`scdp.devices.resolve`). ``runtime`` is what runs the denoiser: ``torch``, ``onnx``
    (:mod:`scdp.policies.exported`, on the CPU) or ``auto``.

    A field left ``None`` takes its value from ``profile`` when a planner loads (:meth:`for_method`):
    ``trained`` plans as the checkpoints were evaluated (their own sampler, cold, torch), ``realtime``
    with the fast planner that passed the real-time gate (:data:`REALTIME`: DDPM-8 warm-started at
    step 4, or at half of ``steps`` when those are given; ONNX Runtime where a graph is exported and the
    device resolves to the CPU) for the methods the
    gate covered (a :class:`~scdp.planners.PlannerKind` with ``realtime``); LD and the paper's design keep their trained sampler. Each entry
    point's profile is in :data:`ENTRY_PROFILES`, and a flag given always wins.

    Each field's ``metadata`` is its command-line flag (argparse keywords), so a new option is one
    field here: :func:`scdp.cli.parser_common.planning_args` adds the flag and :meth:`from_args` reads it back.
    """

    sampler: str | None = field(default=None, metadata={
        "choices": list(SAMPLERS),
        "help": "planning-time sampler, replacing the one saved with the checkpoints (the cpu preset's: ddpm). ddim "
                "and dpmsolver are deterministic; on the cpu preset they lengthen Block Reach's paths "
                "(results/benchmarks/sampler_sweep_*.md). No retraining is needed. Default: the --profile's"})
    steps: int | None = field(default=None, metadata={
        "type": int,
        "help": "denoising steps of the sampler (default: the --profile's; trained: the checkpoints', cpu preset 20; "
                f"realtime: {REALTIME['steps']})"})
    warm_skip: int | None = field(default=None, metadata={
        "type": int,
        "help": "warm start: each chunk starts from the previous chunk's plan, shifted and re-noised to this step "
                "of the sampler's steps, so it costs steps - warm_skip network calls (0: from pure noise; default: "
                f"the --profile's, trained 0, realtime {REALTIME['warm_skip']}). A chunk still starts cold at an episode's start, after a "
                "style change, or when the robot is off its plan. No retraining is needed"})
    device: str = field(default="cpu", metadata=DEVICE_FLAG)
    runtime: str | None = field(default=None, metadata={
        "choices": list(RUNTIMES),
        "help": "what runs the denoiser: torch, onnx (the graph scdp export wrote beside each diffusion checkpoint, "
                f"run by ONNX Runtime on the CPU) or auto (the graph below {AUTO_BATCH} scenes per call where one is exported, "
                "torch otherwise). The sampling loop, the style predictors and the encoder stay in torch; the same "
                "seed draws the same noise. Default: the --profile's (trained: torch; realtime: auto on the CPU, "
                "torch on a GPU)"})
    profile: str = field(default="trained", metadata={
        "choices": list(PROFILES), "default": "trained",
        "help": "what the options left unset plan with: trained (the checkpoints' own sampler, cold, torch: what "
                f"evaluate and reproduce report) or realtime ({_FAST}, ONNX Runtime where "
                "exported, for dp and scdp; it passed the non-inferiority gate in "
                "results/benchmarks/realtime_gate.md; ld and scdp_paper keep their trained sampler)"})

    cuda_graphs: str = field(default="on", metadata={
        "choices": ["on", "off"], "default": "on",
        "help": "on a CUDA device, replay each kind of chunk's denoising loop from a CUDA graph captured at its first "
                "use (on; the plans equal the eager loop's to float32 rounding: tests/test_gpu.py) or run it eagerly "
                "(off). Ignored on the CPU"})

    def _check(self):
        if self.cuda_graphs not in ("on", "off"):
            raise ScdpError("--cuda-graphs", f"on or off, got {preview(str(self.cuda_graphs))}")
        if self.warm_skip is not None and (not isinstance(self.warm_skip, int) or self.warm_skip < 0):
            raise ScdpError("--warm-skip", f"must be an integer >= 0, got {preview(str(self.warm_skip))}")
        if self.runtime is not None and self.runtime not in RUNTIMES:
            raise ScdpError("--runtime", f"one of {', '.join(RUNTIMES)}, got {preview(str(self.runtime))}")
        if self.runtime in ("onnx", "auto") and self.device not in ("cpu", "auto"):
            raise ScdpError("--runtime", f"{self.runtime} runs on the CPU (ONNX Runtime); pass --device cpu, not "
                                         f"{preview(str(self.device))}")
        if self.profile not in PROFILES:
            raise ScdpError("--profile", f"one of {', '.join(PROFILES)}, got {preview(str(self.profile))}")

    @classmethod
    def of_entry(cls, entry: str, **given) -> PlanningOptions:
        """The options of an entry point of :data:`ENTRY_PROFILES` (``plan``, ``control_loop``, ...)."""
        return cls(**{"profile": ENTRY_PROFILES[entry], **given})

    def for_method(self, method: str) -> PlanningOptions:
        """These options with every unset field filled from the profile, for a
        :attr:`PlannerSpec.method` (``dp``, ``scdp``, ``ld``, ...); idempotent."""
        values = REALTIME if self.profile == "realtime" and planners.kind(method).realtime else TRAINED
        filled = {k: v for k, v in values.items() if getattr(self, k) is None}
        if values is REALTIME and "warm_skip" in filled and self.steps is not None:  # the same share of other step counts
            filled["warm_skip"] = self.steps * REALTIME["warm_skip"] // REALTIME["steps"]
        if filled.get("runtime") == "auto" and self.device not in ("cpu", "auto"):
            filled["runtime"] = "torch"  # a GPU runs the torch network (its CUDA graph), not ONNX Runtime
        return replace(self, **filled)

    @classmethod
    def flags(cls, profile: str = "trained") -> list[tuple[str, dict]]:
        """(``--flag``, argparse keywords) of each field, in order; ``--profile`` defaults to ``profile``."""
        out = [("--" + f.name.replace("_", "-"), dict(f.metadata)) for f in fields(cls)]
        return [(flag, {**kw, "default": profile}) if flag == "--profile" else (flag, kw) for flag, kw in out]

    @classmethod
    def from_args(cls, args) -> PlanningOptions:
        """The options of a parsed command line (one attribute per field, as :meth:`flags` adds them)."""
        return cls(**{f.name: getattr(args, f.name) for f in fields(cls)})
