"""Every planner by name, in one table: what ``--methods`` accepts, what each reads, how it loads.

A planner is one :class:`PlannerKind`, registered once with :func:`register`. Everything that used
to be decided by name reads it: :class:`~scdp.config.PlannerSpec` checks names against it and folds
``scdp_<mode>`` into ``scdp``; :func:`scdp.policies.loaders.load_method` loads by its ``family`` (or
by its own ``load``); the service, ``deploy`` and ``loaded_parts`` read its ``parts`` and
``denoiser``; the real-time profile reads ``realtime``; a model set trains the union of the
evaluated planners' ``trains`` (:func:`scdp.training.recipe.model_parts`).

Adding a planner (docs/planners.md)::

    from scdp.planners import PlannerKind, register

    def load_straight(spec, checkpoints, task, planning, **options):   # -> a scdp.policies.base.Planner
        return StraightLine(task)

    register(PlannerKind("straight", family="straight", parts=(), denoiser=None, load=load_straight))

after which ``PlannerSpec.parse("straight")``, ``load_method`` and ``scdp evaluate --methods dp
straight`` take it in that process. From the shell, and in every process a run starts (Ray workers),
a package declares it instead as an entry point of the group ``scdp.planners``
(``straight = "my_package.planners:STRAIGHT"``, a :class:`PlannerKind`), loaded the first time its name
is asked for. This module is a leaf: it imports only other leaves, so a kind's ``load`` is a callable
the registrant supplies.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from importlib.metadata import entry_points
from typing import Callable

from scdp.errors import ScdpError
from scdp.keys import DESIGNS, LD_METHODS, PAPER_METHOD, SCDP_METHODS, STUDENT_PART, STYLES, style_part
from scdp.messages import preview

PLANNER_GROUP = "scdp.planners"  # installed planners: name = "package.module:KIND"
FAMILIES = ("dp", "ld", "scdp")  # the families scdp's own loader builds (scdp.policies.loaders.FAMILY_LOADERS)
SCDP = "scdp"  # the one planner that takes a style mode; scdp_<mode> fixes one


@dataclass(frozen=True)
class PlannerKind:
    """One planner: its name, what it is built from, and what it needs.

    ``family``: ``dp``, ``ld`` or ``scdp`` (built by scdp's loader for that family), or the planner's
    own word when ``load`` builds it. ``parts``: the checkpoint folders it reads. ``denoiser``: the
    part whose denoiser it runs (``--runtime`` places it, ``scdp export`` writes its graph), or None.
    ``design``: for the scdp family, whose style predictors (``scdp`` or ``scdp_paper``).
    ``style``: the style mode a fixed-style name plans with (``scdp_legible``: ``legible``); such a
    name is ``scdp`` with that mode. ``takes_style``: a style mode may be asked of it (``scdp``,
    ``scdp_student``: ``scdp_student:legible``).
    ``realtime``: the real-time profile plans it with the gated fast sampler. ``authors``: it plans
    with the authors' settings, not the tuned ones (``ld_paper``: the paper's guidance).
    ``trains``: the parts a model set trains when it is evaluated. ``load``:
    ``(spec, checkpoints, task, planning, **options) -> Planner``, None for the family's loader.
    """

    name: str
    family: str
    parts: tuple[str, ...]
    denoiser: str | None = "base"
    design: str | None = None
    style: str | None = None
    takes_style: bool = False
    realtime: bool = False
    authors: bool = False
    trains: tuple[str, ...] = ()
    load: Callable | None = None

    def __post_init__(self):
        if not self.name.isidentifier():
            raise ScdpError("planner", f"a planner's name is a Python identifier, got {self.name!r}")
        if self.load is None and self.family not in FAMILIES:
            raise ScdpError(f"planner {self.name}", f"family {self.family!r} has no loader in scdp; give the kind a load")
        if self.denoiser is not None and self.denoiser not in self.parts:
            raise ScdpError(f"planner {self.name}", f"its denoiser {self.denoiser!r} is not among its parts {self.parts}")


REGISTRY: dict[str, PlannerKind] = {}


def register(kind: PlannerKind, *, replace: bool = False) -> PlannerKind:
    """Add ``kind`` to the table (a name already there is refused unless ``replace``)."""
    if kind.name in REGISTRY and not replace:
        raise ScdpError("planner", f"{kind.name!r} is already registered")
    REGISTRY[kind.name] = kind
    return kind


def unregister(name: str) -> None:
    """Remove a planner registered from outside scdp (a test's, say)."""
    REGISTRY.pop(name, None)


@lru_cache(maxsize=1)
def _installed() -> dict:
    """The planners installed packages declare (entry points of :data:`PLANNER_GROUP`), by name, not loaded: read
    once per process (a scan of every installed package's metadata takes milliseconds; a service asks per request)."""
    return {p.name: p for p in entry_points(group=PLANNER_GROUP)}


def names() -> tuple[str, ...]:
    """Every planner's name: scdp's own, then those registered or installed."""
    return (*REGISTRY, *(n for n in _installed() if n not in REGISTRY))


def kind(name: str, field: str = "method") -> PlannerKind:
    """The planner ``name`` (an installed one is loaded and registered at its first lookup); an unknown one is
    refused on ``field``."""
    if name not in REGISTRY and name in (installed := _installed()):
        _register_installed(installed[name], field)
    if name not in REGISTRY:
        raise ScdpError(field, f"unknown method {preview(name)}; choose from {', '.join(names())}")
    return REGISTRY[name]


def styled() -> tuple[str, ...]:
    """The planners a style mode may be asked of (``scdp``, ``scdp_student``)."""
    return tuple(k.name for k in REGISTRY.values() if k.takes_style)


def denoiser_method(part: str) -> str:
    """The planner a denoiser ``part`` loaded on its own plans as (its profile's options): the first one
    registered that runs it (``base``: dp, ``ld``: ld, ``student``: dp_student)."""
    return next((k.name for k in REGISTRY.values() if k.denoiser == part), "dp")


def _register_installed(point, field: str) -> None:
    try:
        loaded = point.load()
    except Exception as exc:  # a broken plugin names itself, whatever it raised
        raise ScdpError(field, f"planner {point.name!r} ({point.value}) failed to load: "
                               f"{type(exc).__name__}: {preview(str(exc))}") from None
    if not isinstance(loaded, PlannerKind) or loaded.name != point.name:
        raise ScdpError(field, f"entry point {point.name!r} ({point.value}) is not a PlannerKind named {point.name!r}")
    register(loaded)


def _scdp_parts(design: str) -> tuple[str, ...]:
    return ("base", "encoder", *(style_part(s, design) for s in STYLES))


def _register_builtins() -> None:
    register(PlannerKind("dp", "dp", ("base",), realtime=True, trains=("base",)))
    for name in LD_METHODS:  # tuned guidance, the authors'
        register(PlannerKind(name, "ld", ("ld",), denoiser="ld", authors=name != "ld", trains=("ld",)))
    for name, mode in SCDP_METHODS.items():
        register(PlannerKind(name, SCDP, _scdp_parts(SCDP), design=SCDP, style=None if name == SCDP else mode,
                             takes_style=name == SCDP, realtime=True, trains=_scdp_parts(SCDP)[2:]))
    register(PlannerKind(PAPER_METHOD, SCDP, _scdp_parts(PAPER_METHOD), design=PAPER_METHOD,
                         trains=_scdp_parts(PAPER_METHOD)[2:]))
    # The few-step student (scdp.training.distill): DP's and SCDP's planners on the student's network, which
    # is distilled with the predictors' films, so a model set that evaluates either trains all of them.
    student_trains = ("base", *_scdp_parts(SCDP)[2:], STUDENT_PART)
    register(PlannerKind("dp_student", "dp", (STUDENT_PART,), denoiser=STUDENT_PART, trains=student_trains))
    register(PlannerKind("scdp_student", SCDP, (STUDENT_PART, *_scdp_parts(SCDP)[1:]), denoiser=STUDENT_PART,
                         design=SCDP, takes_style=True, trains=student_trains))
    assert set(DESIGNS) == {SCDP, PAPER_METHOD}


_register_builtins()
