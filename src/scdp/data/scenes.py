"""Scenes: which goals a robot faces and which one is its target.

A scene is ``(goals (K, d), target)``: K task-space goals, one of them the target g*, the
others distractors g-. Every random scene in scdp comes from :func:`sample_scene`, drawn from
a named *stream* (:data:`STREAMS`): the demonstrations, the scene encoder's training set, the
validation scenes that tuning may look at, the evaluation scenes, the ambiguity calibration
and the benchmarks each have their own. A stream's generator is seeded with
``SeedSequence([stream id, seed])``, so two streams never give the same scenes, whatever seeds
they are given: training seed 1 cannot train the encoder on evaluation seed 1's scenes.

The authors' six fixed goal pairs are called *layouts* (``task.layouts``, numbered 1..6);
:func:`layout_scenes` gives one with both targets.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from scdp.errors import ScdpError
from scdp.keys import EVENT_KINDS, LAYOUT_IDS, MAX_GOALS, MIN_GOALS, RANDOM, SCENE_MODES, layout_number
from scdp.tasks import Task

Scene = tuple[np.ndarray, int]


@dataclass(frozen=True)
class SceneEvent:
    """The scene changing during a motion: once the robot has taken ``step`` actions, the goals become
    ``goals`` (K, d) and the target ``goals[target]``. ``kind`` says what happened (:data:`EVENT_KINDS`):
    a distractor put down near the target (``appear``), taken away (``vanish``), or the target moved."""

    kind: str
    step: int
    goals: np.ndarray
    target: int

    def __post_init__(self):
        if self.kind not in EVENT_KINDS:
            raise ScdpError("event", f"unknown kind {self.kind!r} (choose from {', '.join(EVENT_KINDS)})")
        if self.step < 1:
            raise ScdpError("event", f"happens after at least one action, got step {self.step}")

# The random streams, one per purpose; a draw for one purpose can never coincide with another's.
DEMOS, ENCODER, VALIDATION, EVALUATION, CALIBRATION, BENCHMARK, STUDY, ATTENTION, TASK_KEY = (
    "demos", "encoder", "validation", "evaluation", "calibration", "benchmark", "study", "attention", "task_key")
# STUDY: the scenes a study shows people; ATTENTION: its check scenes before format 5 (checks are main trials now);
# TASK_KEY: the inputs of a task's behaviour probe (scdp.data.task_key)
STREAMS = (DEMOS, ENCODER, VALIDATION, EVALUATION, CALIBRATION, BENCHMARK, STUDY, ATTENTION, TASK_KEY)


def stream_rng(stream: str, seed: int, part: str = "") -> np.random.Generator:
    """The generator of ``stream`` for ``seed``: distinct streams are independent for any seeds. ``part``
    names a sub-stream (an event family of :mod:`scdp.evaluation.dynamic`), independent of the others
    and of the stream itself; "" is the stream itself."""
    if stream not in STREAMS:
        raise ScdpError("stream", f"unknown random stream {stream!r} (choose from {', '.join(STREAMS)})")
    entropy = [zlib.crc32(stream.encode()), int(seed)] + ([zlib.crc32(part.encode())] if part else [])
    return np.random.default_rng(np.random.SeedSequence(entropy))


def sample_scene(task: Task, rng: np.random.Generator, n_goals: int = 2) -> Scene:
    """One random scene: goals from the task's sampling box, then a uniformly drawn target."""
    goals = task.sample_goals(rng, n_goals)
    return goals, int(rng.integers(n_goals))


def sample_scenes(task: Task, n: int, seed: int, n_goals: int = 2, *, stream: str) -> list[Scene]:
    """``n`` random scenes of one stream (:data:`STREAMS`); the same stream and ``seed`` give the same scenes."""
    rng = stream_rng(stream, seed)
    return [sample_scene(task, rng, n_goals) for _ in range(n)]


def scene_seed(seed: int, scene_set: str, index: int) -> int:
    """The seed of scene ``index`` of a named scene set: its start noise and sampling noise.

    It depends only on the run's seed, the set's name and the scene's place in the set, so a
    scene is rolled out with the same noise by every method, in any batch.
    """
    return int(np.random.SeedSequence([seed, zlib.crc32(scene_set.encode()), index]).generate_state(1)[0])


def stack_scenes(task: Task, scenes: list[Scene]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scenes as arrays for the vectorised ambiguity tests: starts (B, d), goals (B, K, d), targets (B,)."""
    goals = np.stack([np.asarray(g, dtype=np.float64) for g, _ in scenes])
    targets = np.array([t for _, t in scenes])
    return np.repeat(task.start_point[None], len(scenes), axis=0), goals, targets


def check_layout(k, field: str = "layout") -> int:
    """Refuse a layout number outside 1..6."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or int(k) not in LAYOUT_IDS:
        raise ScdpError(field, f"layouts are numbered {LAYOUT_IDS[0]}..{LAYOUT_IDS[-1]}, got {k!r}")
    return int(k)


def layout_scenes(task: Task, k: int, repeats: int = 1) -> list[Scene]:
    """The authors' layout ``k`` (1-based) with both targets, ``repeats`` times."""
    goals = task.layouts[check_layout(k) - 1]
    return [(goals.copy(), t) for _ in range(repeats) for t in (0, 1)]


def check_goal_count(n_goals, mode: str = RANDOM, field: str = "goals") -> int:
    """Refuse a goal count outside 2..5, or other than 2 with the authors' (two-goal) layouts."""
    if isinstance(n_goals, bool) or not isinstance(n_goals, (int, np.integer)) or not MIN_GOALS <= n_goals <= MAX_GOALS:
        raise ScdpError(field, f"a scene holds {MIN_GOALS}..{MAX_GOALS} goals (the target and 1..{MAX_GOALS - 1} "
                               f"distractors), got {n_goals!r}")
    if mode != RANDOM and n_goals != 2:
        raise ScdpError(field, f"the authors' layouts hold 2 goals; {n_goals} goals need random scenes, not {mode!r}")
    return int(n_goals)


def demo_scene(task: Task, mode: str, index: int, rng: np.random.Generator, n_goals: int = 2) -> Scene:
    """The scene of demo ``index`` under a scene mode: a :func:`sample_scene` of ``n_goals`` goals
    (``random``), the six two-goal layouts in turn (``fixed``), or one ``layout_k`` only; for a
    layout, a random target."""
    if mode == RANDOM:
        return sample_scene(task, rng, check_goal_count(n_goals))
    check_goal_count(n_goals, mode)
    if mode == "fixed":
        goals = task.layouts[index % len(task.layouts)]
    elif mode in SCENE_MODES:
        goals = task.layouts[layout_number(mode) - 1]
    else:
        raise ScdpError("scenes", f"unknown scene mode {mode!r} (choose from {', '.join(SCENE_MODES)})")
    return goals, int(rng.integers(len(goals)))


def fan_scene(task: Task, n_goals: int = 3, spread_deg: float = 20.0) -> Scene:
    """A hard scene: ``n_goals`` goals on an arc around the start, ``spread_deg`` apart, centred on
    the direction of the goal box's centre at its distance; the target is the middle one (odd
    ``n_goals``), so a path that bends away from one neighbour bends toward the other and no
    path is legible against both."""
    n_goals = check_goal_count(n_goals)
    if n_goals % 2 == 0:
        raise ScdpError("goals", f"a fan has its target in the middle: an odd number of goals, got {n_goals}")
    start = task.start_point
    centre = (task.goal_low + task.goal_high) / 2
    axis = (centre - start)[:2]
    radius, heading = float(np.linalg.norm(axis)), float(np.arctan2(axis[1], axis[0]))
    angles = heading + np.deg2rad(spread_deg) * (np.arange(n_goals) - n_goals // 2)
    goals = np.repeat(centre[None], n_goals, axis=0)
    goals[:, :2] = start[:2] + radius * np.column_stack([np.cos(angles), np.sin(angles)])
    return task.validate_goals(goals, n_goals // 2, field="fan"), n_goals // 2
