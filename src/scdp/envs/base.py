"""Shared Gymnasium logic for goal-reaching tasks.

Observations are dicts ``{"state": (state_dim,), "goal": (space_dim,), "goals": (n, space_dim)}``
where ``goal`` is the target g* and ``goals`` lists every goal of the scene. Actions are the
absolute next state. An episode terminates when the robot's task-space point enters the
task's success radius and is truncated after ``max_episode_steps`` steps.

``reset(seed=..., options={"goals": [[x, y], ...], "target": 0})`` places a given scene;
without ``goals`` a random scene is drawn from the environment's seeded generator.

An environment is built by its task (``Task.make_env``) and reads it through :class:`EnvTask`: the
tasks layer sits above the environments, so the annotation is this protocol, which every
:class:`scdp.tasks.Task` satisfies.
"""

from __future__ import annotations

from typing import Protocol

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from scdp.errors import ScdpError, finite_array


class EnvTask(Protocol):
    """What an environment reads from its task (:class:`scdp.tasks.Task`)."""

    state_dim: int
    space_dim: int
    control_dt: float  # seconds per step
    max_episode_steps: int
    success_radius: float  # metres, task space
    goal_low: np.ndarray  # the goal sampling box, task space (also drawn by render)
    goal_high: np.ndarray
    workspace_low: np.ndarray  # where goals are accepted (a ground robot's room)
    workspace_high: np.ndarray

    @property
    def start_point(self) -> np.ndarray: ...

    def task_space(self, states) -> np.ndarray: ...

    def validate_goals(self, goals, target=None, *, field: str = "goals") -> np.ndarray: ...

    def sample_goals(self, rng: np.random.Generator, n_goals: int = 2) -> np.ndarray: ...

    def start_state(self, rng: np.random.Generator | None = None) -> np.ndarray: ...


class GoalReachEnv(gym.Env):
    """Base class; subclasses implement the robot through four public hooks:
    ``build_action_space()`` (once, at construction: a ``spaces.Box`` of next states, n = state_dim),
    ``reset_robot(state)`` (each ``reset``: put the robot at the (n,) start state),
    ``apply_action(action)`` (each ``step``: move for one ``control_dt`` seconds toward the (n,)
    commanded next state) and ``draw(fig)`` (each ``render``: draw on a matplotlib figure)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, task: EnvTask, *, n_goals: int = 2, render_mode: str | None = "rgb_array", start_noise: bool = True):
        self.task = task
        self.n_goals = n_goals
        self.render_mode = render_mode
        self.start_noise = start_noise
        big = np.inf
        self.observation_space = spaces.Dict(
            {
                "state": spaces.Box(-big, big, (task.state_dim,), np.float64),
                "goal": spaces.Box(-big, big, (task.space_dim,), np.float64),
                "goals": spaces.Box(-big, big, (n_goals, task.space_dim), np.float64),
            }
        )
        self.action_space = self.build_action_space()
        self.goals = np.zeros((n_goals, task.space_dim))
        self.target = 0
        self.trail: list[np.ndarray] = []
        self._steps = 0

    # -- robot-specific hooks ----------------------------------------------------------------
    def build_action_space(self) -> spaces.Box:
        raise NotImplementedError

    def reset_robot(self, state: np.ndarray) -> None:
        raise NotImplementedError

    def apply_action(self, action: np.ndarray) -> None:
        raise NotImplementedError

    @property
    def state(self) -> np.ndarray:
        raise NotImplementedError

    def draw(self, fig) -> None:
        raise NotImplementedError

    # -- Gymnasium API -------------------------------------------------------------------------
    @property
    def position(self) -> np.ndarray:
        """Task-space point of the robot (TCP or base)."""
        return self.task.task_space(self.checked_state())

    def checked_state(self) -> np.ndarray:
        """:attr:`state`, refused on ``state`` (the hook that made it) when it is not (state_dim,) finite numbers."""
        state = np.asarray(self.state, dtype=np.float64)
        if state.shape != (self.task.state_dim,):
            raise ScdpError("state", f"the environment's state must have shape ({self.task.state_dim},), got {state.shape}")
        return finite_array(state, "state")

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = dict(options or {})
        if options.get("goals") is not None:
            target = options.get("target", 0)
            self.goals = self.task.validate_goals(options["goals"], target)
            self.target = int(target)
        else:
            self.goals = self.task.sample_goals(self.np_random, self.n_goals)
            self.target = int(self.np_random.integers(len(self.goals)))
        self.n_goals = len(self.goals)
        start = options.get("start_state")
        if start is None:
            start = self.task.start_state(self.np_random if self.start_noise else None)
        self.reset_robot(finite_array(start, "start_state", (self.task.state_dim,)))
        self._steps, self.trail = 0, []
        return self._observe()

    def move_goals(self, goals, target: int) -> None:
        """Change the scene during the episode (a goal appears, vanishes or moves): ``goals`` (K, d) and
        the target's index, checked as :meth:`reset`'s are. The next observation, the success test and
        the drawing read them; the trail so far is kept."""
        self.goals = self.task.validate_goals(goals, target)
        self.target, self.n_goals = int(target), len(self.goals)
        self.place_goals()

    def place_goals(self) -> None:  # noqa: B027 (an optional hook: most environments draw from self.goals)
        """Hook: show :attr:`goals` in a simulator that keeps its own copy of them (MuJoCo's blocks),
        after :meth:`move_goals`. An environment that reads ``self.goals`` where it needs them has
        nothing to do."""

    def step(self, action):
        action = finite_array(action, "action", (self.task.state_dim,))
        self.apply_action(action)
        self._steps += 1
        obs, info = self._observe()
        terminated = bool(info["success"])
        truncated = self._steps >= self.task.max_episode_steps
        return obs, float(terminated), terminated, truncated, info

    def _observe(self) -> tuple[dict, dict]:
        """(observation, info) of the state now, its position appended to the trail: the state is
        read and checked once, its position computed once (reset and every step)."""
        state = self.checked_state()
        position = self.task.task_space(state)
        self.trail.append(position)
        dist = float(np.linalg.norm(position - self.goals[self.target]))
        obs = {"state": state.copy(), "goal": self.goals[self.target].copy(), "goals": self.goals.copy()}
        return obs, {"distance": dist, "success": dist < self.task.success_radius, "position": position.copy()}

    def render(self):
        """Headless RGB image (H, W, 3) of the scene, drawn with matplotlib's Agg backend (before any
        :meth:`reset`, the scene of the task's first layout at its nominal start)."""
        if not self.trail:
            self.reset(seed=0, options={"goals": self.task.layouts[0], "target": 0,
                                        "start_state": self.task.nominal_start()})
        fig = Figure(figsize=(6, 4), dpi=80)
        canvas = FigureCanvasAgg(fig)
        self.draw(fig)
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[..., :3].copy()
