"""What ``scdp study power`` simulates: :class:`PowerSettings`, each field carrying its flag
(:func:`scdp.study.rules.flag`). Kept apart from :mod:`scdp.study.power` so the command line reads the
flags without importing the analysis stack."""

from __future__ import annotations

from dataclasses import dataclass, field

from scdp.errors import ScdpError
from scdp.study.quantities import POWERED
from scdp.study.record import SETS, Study
from scdp.study.rules import flag


@dataclass(frozen=True)
class PowerSettings:
    """What ``scdp study power`` simulates (each is printed with its result)."""

    a: str = field(default="scdp", metadata=flag(str, "the method claimed more legible"))
    b: str = field(default="dp", metadata=flag(str, "the method it is compared with"))
    quantity: str = field(default="correct_at_50", metadata=flag(  # read per response (scdp.study.analysis)
        str, f"what each response gives, one of {', '.join(POWERED)}"))
    scene_set: str = field(default=SETS[0], metadata=flag(str, "the scene set the claim is about", flag="--set"))
    participants: tuple[int, ...] = field(default=(12, 24, 48, 96), metadata=flag(
        ("int_in", 1, 10000), "the sizes to try, multiples of the methods", nargs="+", metavar="N"))
    replicates: int = field(default=100, metadata=flag(("int_in", 10, 100000), "simulated studies per size"))
    samples: int = field(default=500, metadata=flag(("int_in", 100, 100000), "bootstrap resamples per simulated study"))
    target: float = field(default=0.8, metadata=flag(
        ("float_in", 0, 1, {"lo_open": True, "hi_open": True}), "the power the recommended size reaches"))
    dropout: float = field(default=0.0, metadata=flag(
        ("float_in", 0, 1, {"hi_open": True}), "share of participants lost at random to the screens not simulated "
                                                "(away, playback, ...)"))
    seed: int = field(default=0, metadata=flag("seed", "the simulated studies' draws"))

    def check(self, study: Study) -> None:
        methods = study.config.methods
        for name, method in (("--a", self.a), ("--b", self.b)):
            if method not in methods:
                raise ScdpError(name, f"{method!r} is not a method of this study ({', '.join(methods)})")
        if self.a == self.b:
            raise ScdpError("--b", f"compares two methods, got {self.a!r} twice")
        if self.quantity not in POWERED:
            raise ScdpError("--quantity", f"must be one of {', '.join(POWERED)}, got {self.quantity!r}")
        if self.scene_set not in SETS:
            raise ScdpError("--set", f"must be one of {', '.join(SETS)}, got {self.scene_set!r}")
        bad = [n for n in self.participants if n < len(methods) or n % len(methods)]
        if bad or not self.participants:
            raise ScdpError("--participants", f"sizes are multiples of the {len(methods)} methods (a full Latin square), "
                                              f"got {list(self.participants)}")
        if not 0.0 <= self.dropout < 1.0:
            raise ScdpError("--dropout", f"must be from 0 to below 1, got {self.dropout}")
