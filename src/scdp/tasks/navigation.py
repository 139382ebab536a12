"""Navigation: a TurtleBot3 Burger driving from the origin to one of the goals in a room."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scdp.ambiguity import AmbiguitySettings
from scdp.envs.navigation import NavigationEnv
from scdp.robots import turtlebot
from scdp.tasks.base import Task, fixed_layouts


@dataclass(frozen=True, eq=False)
class NavigationTask(Task):
    """TurtleBot3 Burger driving from (0, 0, 0) to one of the goals. State: (x, y, theta)."""

    def task_space(self, states) -> np.ndarray:
        return np.asarray(states, dtype=np.float64)[..., :2]

    def nominal_start(self) -> np.ndarray:
        return np.zeros(3)

    def actions_for_path(self, path, start_state):
        """Turn on the spot towards the path first, then follow it with tangent headings."""
        heading = np.arctan2(np.diff(path[:, 1]), np.diff(path[:, 0]))
        follow = np.column_stack([path[1:], heading])
        turn = float(turtlebot.wrap_angle(heading[0] - start_state[2]))
        n_turn = int(np.ceil(abs(turn) / (0.8 * turtlebot.MAX_ANGULAR_SPEED * self.control_dt)))
        spin = [[*start_state[:2], start_state[2] + turn * (k + 1) / n_turn] for k in range(n_turn)]
        return np.vstack([np.reshape(spin, (-1, 3)), follow])

    def make_env(self, **kwargs):
        return NavigationEnv(self, **kwargs)

    position_margin = 0.5  # metres beyond the room's walls a reported position may lie (odometry drift)

    @property
    def state_names(self):
        return ("x", "y", "heading")

    def state_bounds(self):
        """The room (:attr:`workspace_low`..:attr:`workspace_high`, whose walls the simulator
        clamps the robot to) widened by :attr:`position_margin`; the heading, kept unwrapped,
        within pi plus the most the robot can turn in one episode (``max_episode_steps`` periods at
        the datasheet turn rate), about +-230 rad."""
        turn = np.pi + self.max_episode_steps * turtlebot.MAX_ANGULAR_SPEED * self.control_dt
        low = np.array([*(self.workspace_low - self.position_margin), -turn])
        high = np.array([*(self.workspace_high + self.position_margin), turn])
        return low, high

    def reach_used(self, states, actions):
        delta = np.asarray(actions, dtype=np.float64) - np.asarray(states, dtype=np.float64)
        move = np.linalg.norm(delta[:, :2], axis=1) / (turtlebot.MAX_LINEAR_SPEED * self.control_dt)
        turn = np.abs(turtlebot.wrap_angle(delta[:, 2])) / (turtlebot.MAX_ANGULAR_SPEED * self.control_dt)
        return np.maximum(move, turn)


NAVIGATION = NavigationTask(
    name="navigation",
    state_dim=3,
    space_dim=2,
    goal_low=np.array([0.5, -1.5]),
    goal_high=np.array([3.0, 1.5]),
    workspace_low=np.array([-0.5, -2.5]),
    workspace_high=np.array([4.0, 2.5]),
    success_radius=0.15,
    step_size=0.02,
    min_goal_separation=0.15,  # layout 2 has goals 0.206 m apart
    control_dt=0.2,  # 0.1 m/s at 2 cm per state leaves the wheels room to turn
    max_episode_steps=400,
    lateral_max=1.0,
    lateral_cap=2.0,
    lift_max=0.0,
    layouts=fixed_layouts(
        [
            [(2.0, 0.2), (2.0, -0.2)],
            [(1.55, -0.4), (1.6, -0.2)],
            [(2.2, 0.1), (2.1, 0.4)],
            [(1.5, 0.9), (1.5, -0.9)],
            [(1.8, 0.7), (1.8, -0.7)],
            [(1.7, -0.8), (2.2, 0.9)],
        ]
    ),
    ambiguous_layouts=(1, 2, 3),
    ambiguity=AmbiguitySettings(beta=4.0, tau=0.1487, kappa=0.99, eccentricity=0.94),
    start_noise=np.array([0.01, 0.01, 0.02]),
)
