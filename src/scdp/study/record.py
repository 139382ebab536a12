"""What ``study.json`` holds, typed: the settings of ``scdp study make`` (:class:`StudyConfig`,
:class:`Screening`) and the study it wrote (:class:`Study`, its :class:`Stimulus` records and
their :class:`View`). :meth:`Study.from_dict` checks a file's record field by field, so a study
folder edited by hand or written by another version is refused in one line naming the field.
"""

from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass, field, fields
from functools import cached_property

import numpy as np

from scdp import planners
from scdp.errors import ScdpError
from scdp.keys import AMBIGUOUS, CLEAR, MAX_GOALS
from scdp.study.rules import AHEAD_OBSERVERS, Screening, flag, flags_of  # noqa: F401 (AHEAD_OBSERVERS: read here)

FORMAT = 7  # 7: every scene toward every goal, a target per participant (design.scene_targets); 6: the task's
#            success radius recorded (an attention check ends clear of every other goal); 5: checks are main trials;
#            4: motions at the robot's own speed, a secret salt; 3: instructed checks
# the last commit of scdp that reads each older format (this repository's history; the package's version did not change)
READ_BY = {1: "a01b980", 2: "3ea8c3a", 3: "40bad6e", 4: "74f6d09", 5: "6fbd00d", 6: "521daf4"}
PRACTICE, MAIN, ATTENTION, INSTRUCTED = "practice", "main", "attention", "instructed"
KINDS = (PRACTICE, MAIN, ATTENTION, INSTRUCTED)  # a trial's kind
STIMULUS_KINDS = (PRACTICE, MAIN)  # a stimulus's
CHECKS = (ATTENTION, INSTRUCTED)  # main trials that also screen participants (design.assignment)
ANALYSED = (MAIN, ATTENTION)  # kinds of trial analysed as data: an attention check is a main trial graded at its end
SETS = (AMBIGUOUS, CLEAR)
DEFAULT_METHODS = ("dp", "ld", "scdp")
PICK_INTERVAL_S = 0.1  # s: picks closer together are refused (StudyConfig.pick_interval_s)
VIEWS = ("top", "camera")  # Navigation: the page draws the path; Block Reach: JPEG frames from across the table


@dataclass(frozen=True)
class StudyConfig:
    """The settings of ``scdp study make`` (each is recorded in ``study.json``)."""

    methods: tuple[str, ...] = field(default=DEFAULT_METHODS, metadata=flag(  # by name (scdp evaluate --methods)
        str, "the planners compared", nargs="+", choices=list(planners.names()), metavar="METHOD"))
    scenes_per_set: int = field(default=6, metadata=flag(
        "count", "ambiguous and clear scenes each, a multiple of the methods", flag="--scenes"))
    attention: int = field(default=2, metadata=flag(
        int, "attention checks per participant: main trials, each a motion that ends clearly at its target, graded by "
             "where it ends"))
    instructed: int = field(default=1, metadata=flag(
        int, "instructed-response checks per participant: at a motion's end the page says which goal to choose, "
             "whatever the robot did"))
    seed: int = field(default=0, metadata=flag(  # the "study" stream's scenes, rollout noise, every participant's draws
        "seed", "scenes, noise and every participant's draws"))
    salt: str = field(default="", metadata=flag(  # never served: "" (studies made before it) none
        str, "the study's secret, mixed into every one of those draws and never served; give a study's own to make it "
             "again", default_text="a fresh random one, kept in study.json"))
    duration_s: float = field(default=6.0, metadata=flag(  # every motion at the same speed (Study.point_s)
        float, "seconds the median main motion plays; every motion plays at that one speed, so a longer path plays "
               "longer"))
    fps: int = field(default=15, metadata=flag(int, "Block Reach: frames per second of motion"))
    completion_code: str = field(default="", metadata=flag(str, "the code of a finished participant",
                                                           default_text="a random one"))
    declined_code: str = field(default="", metadata=flag(  # the platform's "no consent" code
        str, "the code of one who does not consent", default_text="a random one"))
    screened_code: str = field(default="", metadata=flag(str, "the code of one who fails the comprehension check twice",
                                                         default_text="a random one"))
    completion_url: str = field(default="", metadata=flag(
        str, "where a participant is sent at the end (finished, declined or screened out), {code} replaced by its code "
             "(e.g. https://app.prolific.com/submissions/complete?cc={code})", default_text="none, the code is shown"))
    max_picks: int = field(default=12, metadata=flag(
        int, f"picks accepted per trial; more, or faster than {PICK_INTERVAL_S:g} s apart, are refused and counted"))
    slot_timeout_min: float = field(default=60.0, metadata=flag(
        float, "minutes after which a participant who consented but has not finished frees their Latin-square row for "
               "the next one"))
    # the server's timing rules (seconds of its clock) and the comprehension check's
    pick_interval_s: float = PICK_INTERVAL_S  # picks closer together than this are refused: no person clicks faster
    end_tolerance_s: float = 0.05  # a Confirm this close to the motion's end counts as after it (clock granularity)
    lookahead_s: float = 0.2  # how far ahead of the server's clock the page may hold the motion: two of its polls
    comprehension_attempts: int = 2  # failed comprehension checks before a participant is screened out
    screening: Screening = field(default_factory=Screening)

    @classmethod
    def flags(cls) -> list[tuple[str, dict]]:
        """(``--flag``, argparse keywords) of each setting ``scdp study make`` takes: the command line's one source."""
        return flags_of(cls)

    @classmethod
    def from_args(cls, args) -> "StudyConfig":
        """The settings of a parsed command line, its screening rules too."""
        values = {f.name: getattr(args, f.name) for f in fields(cls) if f.metadata}
        return cls(**{**values, "methods": tuple(values["methods"])}, screening=Screening.from_args(args))

    def __post_init__(self):
        if not self.methods or len(set(self.methods)) != len(self.methods):
            raise ScdpError("--methods", f"must name distinct planners, got {list(self.methods)}")
        if not 1 <= self.scenes_per_set <= 200 or self.scenes_per_set % len(self.methods):
            raise ScdpError("--scenes", f"must be a multiple of the {len(self.methods)} methods from 1 to 200, "
                                        f"got {self.scenes_per_set}")
        if not 0 <= self.attention <= 10:
            raise ScdpError("--attention", f"must be from 0 to 10, got {self.attention}")
        if not 0 <= self.instructed <= 10:
            raise ScdpError("--instructed", f"must be from 0 to 10, got {self.instructed}")
        if self.attention + self.instructed > 2 * self.scenes_per_set:
            raise ScdpError("--attention", f"{self.attention} attention and {self.instructed} instructed checks are main "
                                           f"trials: at most the {2 * self.scenes_per_set} a participant sees (2 x --scenes)")
        timing = {"pick_interval_s": self.pick_interval_s, "end_tolerance_s": self.end_tolerance_s,
                  "lookahead_s": self.lookahead_s}
        for name, value in timing.items():
            if not 0.0 <= value <= 1.0:
                raise ScdpError(name, f"must be from 0 to 1 second, got {value}")
        if not 1 <= self.comprehension_attempts <= 10:
            raise ScdpError("comprehension_attempts", f"must be from 1 to 10, got {self.comprehension_attempts}")
        if not 2 <= self.max_picks <= 100:
            raise ScdpError("--max-picks", f"must be from 2 to 100, got {self.max_picks}")
        codes = [c for c in (self.completion_code, self.declined_code, self.screened_code) if c]
        if len(set(codes)) != len(codes) or any(not c.isalnum() or len(c) > 32 for c in codes):
            raise ScdpError("--completion-code", "the finished, declined and screened-out codes must differ, each up "
                                                 f"to 32 letters and digits, got {codes}")
        if not 1.0 <= self.duration_s <= 60.0:
            raise ScdpError("--duration-s", f"must be from 1 to 60 seconds, got {self.duration_s}")
        if not 5 <= self.fps <= 30:
            raise ScdpError("--fps", f"must be from 5 to 30 frames per second, got {self.fps}")
        if self.completion_url and not self.completion_url.startswith(("https://", "http://")):
            raise ScdpError("--completion-url", f"must be an http(s) URL, got {self.completion_url[:40]!r}")
        if self.salt and (len(self.salt) > 64 or any(c not in "0123456789abcdef" for c in self.salt)):
            raise ScdpError("--salt", f"must be up to 64 lowercase hexadecimal digits, got {self.salt[:16]!r}")
        if not 1.0 <= self.slot_timeout_min <= 7 * 24 * 60:
            raise ScdpError("--slot-timeout-min", f"must be from 1 minute to a week, got {self.slot_timeout_min}")

    @property
    def stream_seed(self) -> int:
        """The seed every stimulus and participant stream is drawn from: ``seed`` mixed with the secret
        ``salt`` (SHA-256), so that the public code and a guessed seed cannot rebuild the study's scenes
        and targets; ``seed`` itself for a study without a salt."""
        if not self.salt:
            return self.seed
        return int.from_bytes(hashlib.sha256(f"{self.seed}:{self.salt}".encode()).digest()[:8], "big") >> 1

    def to_dict(self) -> dict:
        return {**asdict(self), "methods": list(self.methods)}


def frame_rate(fps: float, point_s: float) -> float:
    """Frames per second of motion a camera stimulus is shown at: ``fps``, but never faster than the path's own
    points come (one every ``point_s`` s): a frame between two points would repeat the one before it."""
    return float(min(fps, 1.0 / point_s))


def point_seconds(median_s: float, lengths: list[int]) -> float:
    """Seconds per path point that make the median of paths of ``lengths`` points last ``median_s``."""
    return float(median_s / max(1.0, float(np.median(np.asarray(lengths, dtype=np.float64) - 1))))


def _need(record: dict, key: str, kind, where: str):
    """``record[key]``, checked to be of ``kind``; a missing or wrong field is refused naming ``where.key``."""
    if not isinstance(record, dict) or key not in record:
        raise ScdpError("--study", f"{where}.{key}: missing")
    value = record[key]
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        raise ScdpError("--study", f"{where}.{key}: must be {getattr(kind, '__name__', kind)}, got {type(value).__name__}")
    return value


@dataclass(frozen=True)
class View:
    """How the page shows a stimulus: ``"top"`` (drawn from the task-space path) or ``"camera"``
    (``frames`` by their opaque names, the TCP's and the goals' pixels in a width x height image)."""

    kind: str
    width: int = 0
    height: int = 0
    frames: tuple[str, ...] = ()
    path_px: tuple = ()  # (N, 2) pixels of the path's shown points
    goals_px: tuple = ()  # (K, 2) pixels of the goals

    def to_dict(self) -> dict:
        if self.kind == "top":
            return {"kind": "top"}
        return {"kind": self.kind, "frames": list(self.frames), "width": self.width, "height": self.height,
                "path_px": [list(p) for p in self.path_px], "goals_px": [list(p) for p in self.goals_px]}

    @staticmethod
    def from_dict(record: dict, where: str) -> View:
        kind = _need(record, "kind", str, where)
        if kind not in VIEWS:
            raise ScdpError("--study", f"{where}.kind: must be one of {VIEWS}, got {kind!r}")
        if kind == "top":
            return View("top")
        return View(kind, _need(record, "width", int, where), _need(record, "height", int, where),
                    tuple(_need(record, "frames", list, where)), tuple(map(tuple, _need(record, "path_px", list, where))),
                    tuple(map(tuple, _need(record, "goals_px", list, where))))


@dataclass(frozen=True)
class Stimulus:
    """One method's motion on one scene, as participants are shown it (task-space metres)."""

    kind: str  # PRACTICE or MAIN (a check is a main stimulus: design.assignment)
    method: str
    scene_set: str  # AMBIGUOUS, CLEAR or "practice"
    scene_index: int
    goals: list  # (K, d) goal points
    target: int
    path: list  # (N, d) the path up to its arrival (what the observers see)
    success: bool
    styles: list  # the style of each planned chunk
    view: View

    def to_dict(self) -> dict:
        return {**{k: getattr(self, k) for k in ("kind", "method", "scene_set", "scene_index", "goals", "target",
                                                 "path", "success", "styles")}, "view": self.view.to_dict()}

    @staticmethod
    def from_dict(record: dict, where: str) -> Stimulus:
        kind = _need(record, "kind", str, where)
        if kind not in STIMULUS_KINDS:
            raise ScdpError("--study", f"{where}.kind: must be one of {STIMULUS_KINDS}, got {kind!r}")
        goals, target = _need(record, "goals", list, where), _need(record, "target", int, where)
        if not 2 <= len(goals) <= MAX_GOALS or not 0 <= target < len(goals):
            raise ScdpError("--study", f"{where}: {len(goals)} goals (2 to {MAX_GOALS}) and target {target} do not fit")
        path = _need(record, "path", list, where)
        if len(path) < 2:
            raise ScdpError("--study", f"{where}.path: needs at least 2 points, got {len(path)}")
        return Stimulus(kind, _need(record, "method", str, where), _need(record, "scene_set", str, where),
                        _need(record, "scene_index", int, where), goals, target, path,
                        _need(record, "success", bool, where), _need(record, "styles", list, where),
                        View.from_dict(_need(record, "view", dict, where), f"{where}.view"))


@dataclass(frozen=True)
class Study:
    """A study folder's ``study.json``: the settings, the scenes, every stimulus by its id, and what
    is needed to rerun it (the command, the checkpoints' SHA-256s)."""

    task: str  # what scdp.tasks.get_task takes to find the task again (its name, or module:OBJECT)
    goals: int  # goals per scene
    config: StudyConfig
    success_radius: float  # the task's: a motion that ends within it of the target reached it (metres)
    stimuli: dict  # stimulus id (design.stimulus_id) -> Stimulus
    scenes: list = field(default_factory=list)  # every scene drawn, with its seed
    command: str = ""
    checkpoints: str = ""
    checkpoint_sha256: dict = field(default_factory=dict)
    scdp_version: str = ""
    page_weight_mb: float = 0.0
    arm_drawn: str = ""  # how the camera frames draw the arm (its meshes or capsules); "" for a top view
    format: int = FORMAT

    def ids(self, kind: str) -> list[str]:
        """The stimulus ids of ``kind``, in the file's order."""
        return [k for k, v in self.stimuli.items() if v.kind == kind]

    @cached_property
    def point_s(self) -> float:
        """Seconds between two points of every motion on the page: one speed for all, as the robot executed
        them (one point per control step), scaled so that the median main motion lasts ``duration_s``. A
        motion's duration therefore follows its path length: neither a duration nor a speed says anything
        about the target that the motion shown so far does not."""
        return point_seconds(self.config.duration_s, [len(v.path) for v in self.stimuli.values() if v.kind == MAIN]
                             or [len(v.path) for v in self.stimuli.values()])

    @cached_property
    def frame_fps(self) -> float:
        """Frames per second of motion of the camera stimuli (:func:`frame_rate` of ``config.fps``)."""
        return frame_rate(self.config.fps, self.point_s)

    def motion_s(self, stimulus: str) -> float:
        """How long the stimulus's motion plays, in seconds."""
        return (len(self.stimuli[stimulus].path) - 1) * self.point_s

    def to_dict(self) -> dict:
        return {"format": self.format, "scdp_version": self.scdp_version, "command": self.command, "task": self.task,
                "goals": self.goals, "success_radius": self.success_radius, "config": self.config.to_dict(),
                "checkpoints": self.checkpoints,
                "checkpoint_sha256": self.checkpoint_sha256, "scenes": self.scenes,
                "stimuli": {k: v.to_dict() for k, v in self.stimuli.items()}, "page_weight_mb": self.page_weight_mb,
                "arm_drawn": self.arm_drawn}

    @staticmethod
    def from_dict(record: dict, source: str = "study.json") -> Study:
        """The study of a parsed ``study.json`` (``source`` names it in a refusal)."""
        if not isinstance(record, dict) or not isinstance(record.get("stimuli"), dict):
            raise ScdpError("--study", f"{source} is not a study of format {FORMAT}")
        if record.get("format") != FORMAT:
            older = READ_BY.get(record.get("format"))
            where = f"scdp at commit {older} (the last to read it) serves and analyses it; " if older else ""
            raise ScdpError("--study", f"{source} is of format {record.get('format')}, this scdp reads format {FORMAT} "
                                       f"({where}a new study is made again with this version)")
        config = dict(_need(record, "config", dict, source))
        try:
            config["methods"] = tuple(config.get("methods", DEFAULT_METHODS))
            config["screening"] = Screening(**config.get("screening", {}))
            settings = StudyConfig(**config)
        except TypeError as exc:
            raise ScdpError("--study", f"{source}: config: {exc}") from None
        except ScdpError as exc:  # a setting out of range: named as the file's field, not the option
            raise ScdpError("--study", f"{source}: config.{exc.field.lstrip('-').replace('-', '_')}: {exc.message}") from None
        stimuli = {k: Stimulus.from_dict(v, f"{source}: stimuli.{k}") for k, v in record["stimuli"].items()}
        radius = _need(record, "success_radius", (int, float), source)
        if isinstance(radius, bool) or not radius > 0:
            raise ScdpError("--study", f"{source}: success_radius: must be a positive number of metres, got {radius!r}")
        return Study(task=_need(record, "task", str, source), goals=_need(record, "goals", int, source), config=settings,
                     success_radius=float(radius), stimuli=stimuli, scenes=record.get("scenes", []), command=record.get("command", ""),
                     checkpoints=record.get("checkpoints", ""), checkpoint_sha256=record.get("checkpoint_sha256", {}),
                     scdp_version=record.get("scdp_version", ""), page_weight_mb=float(record.get("page_weight_mb", 0.0)),
                     arm_drawn=str(record.get("arm_drawn", "")))
