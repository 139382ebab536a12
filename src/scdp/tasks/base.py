"""The task interface: what the rest of the library needs to know about a robot and its scenes.

A :class:`Task` supplies dimensions, the environment, kinematics (state -> task-space point),
scene sampling and validation, how demonstrations bend, its calibrated ambiguity settings, and
the guard rails every state and planned action passes before a robot sees it. The concrete
tasks live beside this module (:mod:`scdp.tasks.navigation`, :mod:`scdp.tasks.block_reach`).

Task space is where goals live: ``(x, y)`` for Navigation, ``(x, y, z)`` of the TCP for
Block Reach (blocks sit at ``z = 0.1``).

The hooks a task of your own overrides, and when the library calls them (n = ``state_dim``, d =
``space_dim``; metres, radians, seconds; an action is the absolute next state):

======================================  ==================================  ===========================================
hook                                    shapes, units                       called
======================================  ==================================  ===========================================
``task_space(states)``                  (..., n) -> (..., d), m             every step of a rollout, scoring, plotting
``nominal_start()``                     (n,)                                each episode's start (plus ``start_noise``)
``actions_for_path(path, start)``       (K, d), (n,) -> (K - 1, n) | None   generating demonstrations, once per demo
``make_env(**kwargs)``                  -> ``GoalReachEnv``                 once per scene of a rollout, deploy, serve
``reach_used(states, actions)``         (T, n), (T, n) -> (T,), 1 = limit   every planned chunk, before a robot sees it
``state_bounds()``                      two (n,)                            every state received and action planned
``check_reachable(goals, field)``       (k, d) -> None, raises ScdpError    every scene a user gives (optional)
======================================  ==================================  ===========================================

The environment's hooks (``build_action_space``, ``reset_robot``, ``apply_action``, ``draw``) are
in :mod:`scdp.envs.base`; docs/tasks.md walks through both with an example arm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from scdp.ambiguity import AmbiguitySettings
from scdp.errors import ScdpError, finite_array
from scdp.keys import MAX_GOALS, MIN_GOALS
from scdp.messages import preview


def fixed_layouts(pairs, z=None) -> np.ndarray:
    """Six two-goal layouts as a (6, 2, space_dim) array: ``pairs`` of 2-D points (``z`` added to
    each when given: goals on a table) or of 3-D points as they are (a goal box that spans z)."""
    arr = np.array(pairs, dtype=np.float64)
    dim = arr.size // 12 if arr.size in (24, 36) else 0
    if not dim:
        raise ScdpError("layouts", f"expected six pairs of 2-D or 3-D points (24 or 36 numbers), got {arr.size}")
    arr = arr.reshape(6, 2, dim)
    if z is not None:
        if dim == 3:
            raise ScdpError("layouts", "the points are 3-D already: give z only with 2-D points")
        arr = np.concatenate([arr, np.full((6, 2, 1), z)], axis=-1)
    return arr


def follow_path(path: np.ndarray, start_state, solve) -> np.ndarray | None:
    """An arm's joint states along a task-space ``path`` (K, space_dim): each point's
    ``solve(point, q_previous) -> (q, converged)`` warm-started from the one before, the first
    from ``start_state``. (K - 1, state_dim), or None as soon as a point is not reached (what
    :meth:`Task.actions_for_path` returns for an arm)."""
    q = np.asarray(start_state, dtype=np.float64)
    out = np.empty((len(path) - 1, len(q)))
    for k, point in enumerate(path[1:]):
        q, ok = solve(point, q)
        if not ok:
            return None
        out[k] = q
    return out


ARRAY_FIELDS = ("goal_low", "goal_high", "workspace_low", "workspace_high", "layouts", "start_noise")
REACH_MARGIN = 1.5
"""Planned actions asking for more than this many times the robot's one-step reach
(:meth:`Task.reach_used`: 1 = the datasheet speed limits over one control period) are refused by
:meth:`Task.check_chunk`, never clipped. Demos stay within 1 and the cpu preset's planners within
1.06, but for ``ld_paper``, whose w0 = 4.5 guidance plans a few chunks at 2-3x (the simulators clip
those; the service refuses them): no policy learned a step of 1.5x (measured for issue 22)."""


@dataclass(frozen=True, eq=False)
class Task:
    """Base class: shared scene logic. Subclasses add the robot-specific parts."""

    name: str
    state_dim: int
    space_dim: int
    goal_low: np.ndarray  # sampling box for random scenes (task space)
    goal_high: np.ndarray
    workspace_low: np.ndarray  # where user goals are accepted
    workspace_high: np.ndarray
    success_radius: float
    step_size: float  # task-space distance between recorded states
    min_goal_separation: float
    control_dt: float
    max_episode_steps: int
    lateral_max: float  # control point offset, in chord lengths (uniform in +-lateral_max)
    lateral_cap: float  # ... but never more than this many metres
    lift_max: float  # extra height of the control point (uniform in [0, lift_max]), metres
    layouts: np.ndarray  # (6, 2, space_dim): the goal pairs of the authors' six fixed layouts
    ambiguous_layouts: tuple[int, ...]  # 1-based numbers of the layouts the authors labelled ambiguous
    ambiguity: AmbiguitySettings  # as found by `scdp ambiguity-report` (see results/ambiguity_*.md)
    start_noise: np.ndarray = field(default_factory=lambda: np.zeros(0))
    # Where a person watching the robot stands and what they look at (task space): the viewpoint
    # observer reads the motion projected into this view (scdp.evaluation.observation). None: the
    # scene is watched from above, in task space as it is (a planar task such as Navigation).
    viewer_eye: tuple | None = None
    viewer_target: tuple | None = None

    def __post_init__(self):
        # the array fields as float arrays, whatever sequence a task was written with (lists, tuples);
        # what cannot be read as numbers is left for the load check to refuse by name (tasks.contract)
        for member in ARRAY_FIELDS:
            value = getattr(self, member)
            if not isinstance(value, np.ndarray):
                try:
                    object.__setattr__(self, member, np.asarray(value, dtype=np.float64))
                except (TypeError, ValueError):
                    pass

    # -- robot-specific, overridden ------------------------------------------------------
    def task_space(self, states) -> np.ndarray:
        """Map states (..., state_dim) to task-space points (..., space_dim)."""
        raise NotImplementedError

    def nominal_start(self) -> np.ndarray:
        """The noise-free start state."""
        raise NotImplementedError

    def actions_for_path(self, path: np.ndarray, start_state: np.ndarray) -> np.ndarray | None:
        """Absolute next-state actions that follow a task-space ``path`` (K, space_dim).

        Returns (K - 1, state_dim), or ``None`` if the robot cannot follow the path.
        """
        raise NotImplementedError

    def make_env(self, **kwargs):
        """A fresh Gymnasium environment for this task."""
        raise NotImplementedError

    def reach_used(self, states, actions) -> np.ndarray:
        """How much of the robot's one-step reach each action asks for: (T,) ratios, where an
        action (the commanded next state) farther from its state than the robot can move in
        ``control_dt`` at its datasheet speed limits gives more than 1."""
        raise NotImplementedError

    def check_reachable(self, goals: np.ndarray, field: str) -> None:
        """Raise ``ScdpError(field, ...)`` if a goal (k, d) is inside the workspace box but the robot
        cannot reach it. Default: every goal is reachable."""

    # -- shared ----------------------------------------------------------------------------
    @property
    def start_point(self) -> np.ndarray:
        """Task-space position of the noise-free start."""
        return self.task_space(self.nominal_start())

    def start_state(self, rng: np.random.Generator | None = None) -> np.ndarray:
        """The start state, with the task's small Gaussian noise when ``rng`` is given."""
        s = self.nominal_start().copy()
        if rng is not None and self.start_noise.size:
            s = s + rng.normal(0.0, self.start_noise)
        return s

    def episode_path(self, episode: dict) -> np.ndarray:
        """Task-space path of a recorded episode: its states, then the final commanded state.

        Recorded states are taken *before* each step, so the final action (the next state)
        closes the path. (T + 1, space_dim).
        """
        return self.task_space(np.vstack([episode["state"], episode["action"][-1:]]))

    @property
    def min_start_distance(self) -> float:
        """Goals must lie at least this far from the start point: twice the success radius, so
        that no goal counts as reached before the robot has moved (and the per-scene reference
        bounds of D and E cannot collapse)."""
        return 2.0 * self.success_radius

    def goal_distance_range(self) -> tuple[float, float]:
        """(j_min, j_max): the smallest allowed and largest possible goal separation.

        The diagonal is summed with ``math.fsum`` (correctly rounded): ``np.linalg.norm`` of a vector
        goes through the BLAS dot, whose last bit differs between CPUs (0.7211102550927978 on one,
        ...979 on another), and every T in ``results/`` is scored with this value."""
        diagonal = math.sqrt(math.fsum(float(d) * float(d) for d in self.goal_high - self.goal_low))
        return self.min_goal_separation, diagonal

    def validate_goals(self, goals, target=None, *, field: str = "goals") -> np.ndarray:
        """Check a scene and return it as a (n, space_dim) float array.

        A 3-D task whose goal box is flat in z (``goal_low[2] == goal_high[2]``: Block Reach's table)
        accepts (n, 2) goals and lifts them to that height; any other task refuses goals of the wrong
        dimension.
        Raises :class:`ScdpError` for NaN/inf, fewer than two goals or more than
        :data:`~scdp.keys.MAX_GOALS`, a goal outside the workspace,
        coincident goals, a goal beyond the robot's reach, a goal closer to the start than
        :attr:`min_start_distance`, or a target that is not an integer index of a goal (``True``
        and ``"1"`` are refused, not read as 1).
        """
        g = finite_array(goals, field)
        if g.ndim != 2:
            raise ScdpError(field, f"expected a list of points, got shape {g.shape}")
        flat = self.space_dim == 3 and self.goal_low[2] == self.goal_high[2]  # every goal at one known height
        if g.shape[1] == 2 and flat:
            g = np.concatenate([g, np.full((len(g), 1), self.goal_low[2])], axis=1)
        if g.shape[1] != self.space_dim:
            lift = (" (2-D goals are lifted only on a 3-D task whose goal box is flat in z, like block_reach's table; "
                    f"this one spans z {self.goal_low[2]:.4g}..{self.goal_high[2]:.4g})"
                    if self.space_dim == 3 and g.shape[1] == 2 else "")
            raise ScdpError(field, f"{self.name} goals have {self.space_dim} coordinates, got {g.shape[1]}{lift}")
        if len(g) < MIN_GOALS:
            raise ScdpError(field, f"need at least two goals (a target and a distractor), got {len(g)}")
        if len(g) > MAX_GOALS:
            raise ScdpError(field, f"at most {MAX_GOALS} goals (a target and {MAX_GOALS - 1} distractors), got {len(g)}")
        # the box first: the distances below then cannot overflow on huge values
        tol = 1e-5  # float32 storage rounds 0.1 to 0.1000000015
        outside = np.any((g < self.workspace_low - tol) | (g > self.workspace_high + tol), axis=1)
        if outside.any():
            k = int(np.argmax(outside))
            raise ScdpError(
                field,
                f"goal {k} {[float(f'{v:.4g}') for v in g[k]]} is outside the {self.name} workspace "
                f"{self.workspace_low.tolist()}..{self.workspace_high.tolist()}",
            )
        d = np.linalg.norm(g[:, None] - g[None], axis=-1) + np.eye(len(g)) * 1e9
        if d.min() < self.min_goal_separation:
            i, j = np.unravel_index(np.argmin(d), d.shape)
            raise ScdpError(
                field, f"goals {i} and {j} are {d[i, j]:.3f} m apart (minimum {self.min_goal_separation} m)"
            )
        self.check_reachable(g, field)
        near = np.linalg.norm(g - self.start_point, axis=1)
        if near.min() < self.min_start_distance:
            k = int(np.argmin(near))
            raise ScdpError(field, f"goal {k} is {near[k]:.3f} m from the start (minimum {self.min_start_distance:.3f} m, "
                                   "twice the success radius)")
        if target is not None:
            if isinstance(target, bool) or not isinstance(target, (int, np.integer)) or not 0 <= target < len(g):
                raise ScdpError("target", f"must be an integer index of one of the {len(g)} goals (0..{len(g) - 1}), "
                                          f"got {preview(target, 24)}")
        return g

    def sample_goals(self, rng: np.random.Generator, n_goals: int = 2) -> np.ndarray:
        """Random goals in the sampling box, at least ``min_goal_separation`` apart. (n, space_dim)."""
        if not MIN_GOALS <= n_goals <= MAX_GOALS:
            raise ScdpError("goals", f"a scene holds {MIN_GOALS}..{MAX_GOALS} goals, got {n_goals}")
        while True:
            g = rng.uniform(self.goal_low, self.goal_high, size=(n_goals, self.space_dim))
            d = np.linalg.norm(g[:, None] - g[None], axis=-1) + np.eye(n_goals) * 1e9
            if d.min() >= self.min_goal_separation:
                return g

    def sample_control_point(self, rng: np.random.Generator, start, target) -> np.ndarray:
        """Bézier control point for a demo from ``start`` to ``target``.

        It sits at a uniform fraction u in [0.3, 0.7] of the chord, pushed sideways (in the
        xy plane, either side) by a uniform ``c`` in ``+-lateral_max`` chord lengths, capped
        at ``lateral_cap`` metres, and lifted by a uniform height in [0, ``lift_max``].
        A uniform (not bell-shaped) ``c`` gives as many strongly curved demos as straight ones.
        """
        start, target = np.asarray(start, float), np.asarray(target, float)
        chord = target - start
        u = rng.uniform(0.3, 0.7)
        c = rng.uniform(-self.lateral_max, self.lateral_max)
        lift = rng.uniform(0.0, self.lift_max) if self.lift_max > 0 else 0.0
        flat = chord[:2]
        length = float(np.linalg.norm(flat))
        normal = np.zeros_like(chord)
        if length > 1e-9:
            normal[:2] = np.array([-flat[1], flat[0]]) / length
        offset = float(np.clip(c * length, -self.lateral_cap, self.lateral_cap))
        point = start + u * chord + offset * normal
        if self.space_dim == 3:
            point[2] += lift
        return point

    def check_task(self, name: str) -> None:
        """Refuse data or checkpoints that belong to another task."""
        if name != self.name:
            raise ScdpError("task", f"made for task {name!r}, but the task is {self.name!r}")

    # -- guard rails for states and planned actions -------------------------------------------
    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of every state the robot can report (subclasses state their margin)."""
        raise NotImplementedError

    @property
    def state_names(self) -> tuple[str, ...]:
        """A name for each state coordinate, for messages."""
        raise NotImplementedError

    def check_states(self, states, field: str = "state", what: str = "state") -> np.ndarray:
        """``states`` (..., state_dim) as float64; refuses non-numbers, NaN/inf and values outside
        :meth:`state_bounds`, naming ``field``, the row (``what`` k, rows counted flat) and the
        coordinate. Only comparisons run before the refusal, so huge values raise no overflow warning."""
        try:
            arr = np.asarray(states, dtype=np.float64)
        except (TypeError, ValueError):
            raise ScdpError(field, f"expected numbers, {self.state_dim} per {what}") from None
        if arr.ndim == 0 or arr.shape[-1] != self.state_dim or arr.size == 0:
            raise ScdpError(field, f"expected {self.state_dim} values per {what}, got shape {arr.shape}")
        rows = arr.reshape(-1, self.state_dim)
        finite = np.isfinite(rows)
        if not finite.all():
            k = int(np.argmin(finite.all(axis=1)))
            raise ScdpError(field, f"{what} {k} contains NaN or inf")
        low, high = self.state_bounds()
        outside = (rows < low) | (rows > high)
        if outside.any():
            k, j = (int(i[0]) for i in np.nonzero(outside))
            raise ScdpError(field, f"{what} {k}: {self.state_names[j]} = {rows[k, j]:.4g} is outside the {self.name} "
                                   f"bounds {low[j]:.4g}..{high[j]:.4g}")
        return arr

    def check_chunk(self, state, actions, field: str = "actions", *, reach: bool = True) -> np.ndarray:
        """A planned chunk ``actions`` (n, state_dim) of absolute next states, checked before a robot
        gets it: every value finite, every action inside :meth:`state_bounds`, and (``reach``) each
        within :data:`REACH_MARGIN` times the one-step reach (:meth:`reach_used`) of the state before it
        (``state`` for the first, then the previous action). Returned as float64, never changed."""
        a = self.check_states(actions, field, what="step")
        a = a.reshape(-1, self.state_dim)
        if not reach:
            return a
        previous = np.vstack([np.asarray(state, dtype=np.float64).reshape(1, -1), a[:-1]])
        reach = self.reach_used(previous, a)
        if np.any(reach > REACH_MARGIN):
            k = int(np.argmax(reach > REACH_MARGIN))
            raise ScdpError(field, f"step {k} asks for {reach[k]:.3g}x the robot's one-step reach (at most "
                                   f"{REACH_MARGIN:g}x is accepted); the plan was not sent")
        return a
