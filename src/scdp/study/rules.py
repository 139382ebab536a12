"""The study's screening rules: who the analysis leaves out, fixed in ``study.json`` before any data exist
(:mod:`scdp.study.screening` applies them). Each rule's field carries its command-line flag (type, help,
choices), so ``scdp study make`` declares none of them again.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields

from scdp.errors import ScdpError

AHEAD_OBSERVERS = ("path_length", "demonstration", "viewpoint", "any")  # scdp.evaluation.observation.OBSERVERS, or all


def flag(kind, help: str, **more) -> dict:
    """A field's command-line flag, as its ``metadata``: ``kind`` (a type; the name of one of ``scdp.cli.types``,
    ``"count"`` or ``"seed"``; or such a name with its bounds, ``("int_in", 1, 1000)``, ``("float_in", 0, 1,
    {"hi_open": True})``, which the parser resolves), its help, and argparse keywords (``flag``: a name other than
    the field's; ``default_text``: what the help says of the default, when not its value)."""
    return {"type": kind, "help": help, **more}


def values_of(cls, args) -> dict:
    """The values a parsed command line gives the flagged fields of ``cls`` (a tuple field as a tuple)."""
    return {f.name: tuple(v) if isinstance(f.default, tuple) else v
            for f in fields(cls) if f.metadata for v in [getattr(args, f.name)]}


def flags_of(cls) -> list[tuple[str, dict]]:
    """(``--flag``, argparse keywords) of each field of ``cls`` that has a flag, in order: the default from the field,
    the help ending with it."""
    out = []
    for f in fields(cls):
        if not f.metadata:
            continue
        name = f.metadata.get("flag", "--" + f.name.replace("_", "-"))
        keywords = {"metavar": name[2:].upper().replace("-", "_"),
                    **{k: v for k, v in f.metadata.items() if k not in ("flag", "default_text")}}
        value = (" ".join(map(str, f.default)) if isinstance(f.default, tuple) else f"{f.default:g}" if isinstance(f.default, float)
                 else f.default)
        shown = f": {f.metadata['default_text']}" if "default_text" in f.metadata else f" {value}"
        out.append((name, {**keywords, "dest": f.name, "default": f.default, "help": f"{keywords['help']} (default{shown})"}))
    return out


@dataclass(frozen=True)
class Screening:
    """Who is left out of the analysis, decided before any data exist (recorded in ``study.json``).
    Each rule gives every excluded participant a reason (:mod:`scdp.study.screening`)."""

    # each field: its value in study.json, and (metadata) its flag's type and help; flags() adds the default
    min_attention: float = field(default=1.0, metadata=flag(float, "share of attention checks to pass"))
    max_replays: int = field(default=0, metadata=flag(int, "reloads of a playing motion allowed, over the whole study"))
    max_lag: float = field(default=0.15, metadata=flag(
        float, "largest median lag of the page's motion behind the server's clock at a pick, as a fraction of the "
               "motion: a slowed or stalled playback"))
    min_confirm_s: float = field(default=0.2, metadata=flag(
        float, "fewest median seconds from a motion's end to Confirm: faster is not a person"))
    min_instructed: float = field(default=1.0, metadata=flag(
        float, "share of instructed-response checks ('choose the red goal') to follow"))
    max_away: int = field(default=2, metadata=flag(
        int, "times the page may be hidden or lose focus while motions play, over the whole study"))
    max_capped: int = field(default=0, metadata=flag(
        int, "trials in which picks may be refused for the cap or the rate"))
    min_first_pick_s: float = field(default=0.3, metadata=flag(
        float, "a trial's first pick sooner than this after Start, on the server's clock, came before anything was "
               "visible to decide on (a person's reaction time and a few frames)"))
    max_early: float = field(default=0.5, metadata=flag(float, "largest share of trials whose first pick came that early"))
    ahead_at: float = field(default=0.25, metadata=flag(
        float, "the fraction of the motion the 'ahead' rule reads picks at: a participant right there, on motions the "
               "--ahead-observer cannot read by then, more often than guessing allows is excluded"))
    ahead_observer: str = field(default="path_length", metadata=flag(
        str, "whose reading of a motion the 'ahead' rule compares with (any: the rule counts only motions none of "
             "the observers reads)", choices=AHEAD_OBSERVERS))
    ahead_delay_s: float = field(default=0.3, metadata=flag(
        float, "how far behind the motion, in seconds, that observer reads it (a fast person's reaction)"))
    ahead_alpha: float = field(default=0.01, metadata=flag(
        float, "the 'ahead' rule's one-sided binomial p below which a participant is excluded (0 turns the rule off); "
               "docs/study.md gives its rate on simulated honest people"))

    def __post_init__(self):
        if not 0.0 <= self.min_attention <= 1.0:
            raise ScdpError("--min-attention", f"must be from 0 to 1, got {self.min_attention}")
        if not 0 <= self.max_replays <= 100:
            raise ScdpError("--max-replays", f"must be from 0 to 100, got {self.max_replays}")
        if not 0.0 < self.max_lag <= 1.0:
            raise ScdpError("--max-lag", f"must be in (0, 1], got {self.max_lag}")
        if not 0.0 <= self.min_confirm_s <= 10.0:
            raise ScdpError("--min-confirm-s", f"must be from 0 to 10 seconds, got {self.min_confirm_s}")
        if not 0.0 <= self.min_instructed <= 1.0:
            raise ScdpError("--min-instructed", f"must be from 0 to 1, got {self.min_instructed}")
        if not 0 <= self.max_away <= 1000:
            raise ScdpError("--max-away", f"must be from 0 to 1000, got {self.max_away}")
        if not 0 <= self.max_capped <= 1000:
            raise ScdpError("--max-capped", f"must be from 0 to 1000, got {self.max_capped}")
        if not 0.0 <= self.min_first_pick_s <= 10.0:
            raise ScdpError("--min-first-pick-s", f"must be from 0 to 10 seconds, got {self.min_first_pick_s}")
        if not 0.0 <= self.max_early <= 1.0:
            raise ScdpError("--max-early", f"must be from 0 to 1, got {self.max_early}")
        if not 0.0 < self.ahead_at <= 0.5:
            raise ScdpError("--ahead-at", f"must be in (0, 0.5] of the motion, got {self.ahead_at}")
        if self.ahead_observer not in AHEAD_OBSERVERS:
            raise ScdpError("--ahead-observer", f"must be one of {', '.join(AHEAD_OBSERVERS)}, got {self.ahead_observer!r}")
        if not 0.0 <= self.ahead_delay_s <= 2.0:
            raise ScdpError("--ahead-delay-s", f"must be from 0 to 2 seconds, got {self.ahead_delay_s}")
        if not 0.0 <= self.ahead_alpha < 1.0:
            raise ScdpError("--ahead-alpha", f"must be from 0 (the rule off) to below 1, got {self.ahead_alpha}")

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def flags(cls) -> list[tuple[str, dict]]:
        """(``--flag``, argparse keywords) of each rule, in order: the command line's one source of them."""
        return flags_of(cls)

    @classmethod
    def from_args(cls, args) -> "Screening":
        """The rules of a parsed command line (one attribute per field, as :meth:`flags` adds them)."""
        return cls(**{f.name: getattr(args, f.name) for f in fields(cls)})
