"""What a study shows and to whom: its settings, its trials, and each participant's assignment.

A study compares ``methods`` on the same scenes. Every method is rolled out on every scene with
the same noise (``scdp study make``), but a participant sees each scene once, under one method:
a Latin square over the methods decides which (participant ``k`` is on row ``k mod M``; scene
``s`` shows method ``(s + row) mod M``), so each participant sees every method equally often and
each (scene, method) pair is seen by every M-th participant. Scenes come in two sets, ambiguous
and clear (eq. 3 of the paper), ``scenes_per_set`` each, a multiple of M.

Each participant's run is: a practice trial, then the main trials and the attention checks (a
straight path to a goal far from the others) in an order of their own. Every trial has a random
mirror image (y -> -y: left and right swap) and a random assignment of colours to goals, so that
neither side nor colour can be a cue. All of it is drawn from the study's seed and the
participant's arrival number, so :func:`assignment` rebuilds any participant's run exactly.
"""

from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass, field

import numpy as np

from scdp.errors import ScdpError
from scdp.keys import AMBIGUOUS, CLEAR

FORMAT = 1
PRACTICE, MAIN, ATTENTION = "practice", "main", "attention"
KINDS = (PRACTICE, MAIN, ATTENTION)
SETS = (AMBIGUOUS, CLEAR)
# goal colours a participant names goals by: distinct for the common colour-vision deficiencies (Okabe-Ito)
PALETTE = (("orange", "#E69F00"), ("sky blue", "#56B4E9"), ("green", "#009E73"), ("yellow", "#F0E442"),
           ("purple", "#CC79A7"))
DEFAULT_METHODS = ("dp", "ld", "scdp")
SIMULATED_PREFIX = "SIM-"  # the IDs of simulated participants (scdp study simulate): never human data


@dataclass(frozen=True)
class StudyConfig:
    """The settings of ``scdp study make`` (each is recorded in ``study.json``)."""

    methods: tuple[str, ...] = DEFAULT_METHODS  # the planners compared, by name (``scdp evaluate --methods``)
    scenes_per_set: int = 6  # ambiguous and clear scenes each; a multiple of len(methods)
    attention: int = 2  # attention-check trials per participant
    seed: int = 0  # scenes (the "study" stream), rollout noise, and every participant's order, mirrors, colours
    duration_s: float = 6.0  # every motion plays over this long: the analysis is per fraction of the motion
    frames: int = 30  # Block Reach: rendered frames per motion
    completion_code: str = ""  # shown at the end (crowdsourcing platforms use one per study); "" draws one

    def __post_init__(self):
        if not self.methods or len(set(self.methods)) != len(self.methods):
            raise ScdpError("--methods", f"must name distinct planners, got {list(self.methods)}")
        if not 1 <= self.scenes_per_set <= 200 or self.scenes_per_set % len(self.methods):
            raise ScdpError("--scenes", f"must be a multiple of the {len(self.methods)} methods from 1 to 200, "
                                        f"got {self.scenes_per_set}")
        if not 0 <= self.attention <= 10:
            raise ScdpError("--attention", f"must be from 0 to 10, got {self.attention}")
        if not 1.0 <= self.duration_s <= 60.0:
            raise ScdpError("--duration-s", f"must be from 1 to 60 seconds, got {self.duration_s}")
        if not 2 <= self.frames <= 200:
            raise ScdpError("--frames", f"must be from 2 to 200, got {self.frames}")

    def to_dict(self) -> dict:
        return {**asdict(self), "methods": list(self.methods)}


@dataclass(frozen=True)
class Trial:
    """One trial of one participant: which stimulus, mirrored or not, and the colour of each goal."""

    index: int  # 0 is the practice trial
    stimulus: str  # a key of study.json's "stimuli"
    kind: str  # PRACTICE, MAIN or ATTENTION
    mirror: bool
    colours: list = field(default_factory=list)  # one palette index per goal, in the stimulus's goal order

    def to_dict(self) -> dict:
        return asdict(self)


def stimulus_id(kind: str, scene_set: str, index: int, method: str) -> str:
    return f"{kind}-{scene_set}-{index:03d}-{method}"


def main_stimuli(study: dict, row: int) -> list[str]:
    """The main stimuli of Latin-square row ``row``: every scene once, scene s under method (s + row) mod M."""
    methods = study["config"]["methods"]
    out = []
    for scene_set in SETS:
        for s in range(study["config"]["scenes_per_set"]):
            out.append(stimulus_id(MAIN, scene_set, s, methods[(s + row) % len(methods)]))
    return out


def _rng(seed: int, purpose: str, number: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([int(seed), zlib.crc32(purpose.encode()), int(number)]))


def assignment(study: dict, number: int) -> list[Trial]:
    """The trials of the participant who arrived ``number``-th (0-based): practice first, then the
    main trials and attention checks shuffled (an attention check never first), each with its mirror
    and goal colours."""
    config = study["config"]
    rng = _rng(config["seed"], "study-participant", number)
    row = number % len(config["methods"])
    main = main_stimuli(study, row)
    order = [main[i] for i in rng.permutation(len(main))]
    checks = [k for k, v in study["stimuli"].items() if v["kind"] == ATTENTION]
    for check in checks:
        order.insert(int(rng.integers(1, len(order) + 1)), check)
    practice = [k for k, v in study["stimuli"].items() if v["kind"] == PRACTICE]
    trials = []
    for i, stim in enumerate(practice + order):
        n_goals = len(study["stimuli"][stim]["goals"])
        trials.append(Trial(index=i, stimulus=stim, kind=study["stimuli"][stim]["kind"], mirror=bool(rng.integers(2)),
                            colours=[int(c) for c in rng.permutation(len(PALETTE))[:n_goals]]))
    return trials


def mirrored(points, mirror: bool) -> list:
    """Task-space points with y negated when ``mirror`` (left and right swap; x and z stay)."""
    p = np.asarray(points, dtype=np.float64).copy()
    if mirror:
        p[..., 1] = -p[..., 1]
    return p.tolist()


def served_trial(study: dict, trial: Trial, n_trials: int) -> dict:
    """What the page gets for a trial: the motion, mirrored and coloured, and never the target."""
    stim = study["stimuli"][trial.stimulus]
    view = dict(stim["view"])
    if trial.mirror and view["kind"] == "camera":
        view["flip"] = True
        view["goals_px"] = [[view["width"] - 1 - u, v] for u, v in view["goals_px"]]
        view["path_px"] = [[view["width"] - 1 - u, v] for u, v in view["path_px"]]
    return {"index": trial.index, "n_trials": n_trials, "kind": trial.kind, "task": study["task"],
            "duration_s": study["config"]["duration_s"], "goals": mirrored(stim["goals"], trial.mirror),
            "path": mirrored(stim["path"], trial.mirror),
            "colours": [{"name": PALETTE[c][0], "hex": PALETTE[c][1]} for c in trial.colours], "view": view}
