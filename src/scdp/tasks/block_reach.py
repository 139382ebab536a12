"""Block Reach: a Franka Panda reaching one of the blocks on a table (MuJoCo)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scdp.ambiguity import AmbiguitySettings
from scdp.envs.block_reach import BlockReachEnv
from scdp.robots import panda
from scdp.tasks.base import Task, fixed_layouts, follow_path


@dataclass(frozen=True, eq=False)
class BlockReachTask(Task):
    """Franka Panda reaching one of the blocks on a table. State: 7 joint positions."""

    def task_space(self, states) -> np.ndarray:
        return panda.tcp_position(states)

    def nominal_start(self) -> np.ndarray:
        return panda.READY_POSE.copy()

    def actions_for_path(self, path, start_state):
        return follow_path(path, start_state, lambda point, q: panda.solve_ik(point, q, tol=5e-4))

    def check_reachable(self, goals, field):
        for k, g in enumerate(goals):
            panda.inverse_kinematics(g, field=f"{field}[{k}]")

    def make_env(self, **kwargs):
        return BlockReachEnv(self, **kwargs)

    joint_margin = 0.05  # rad beyond the datasheet joint limits a reported position may lie

    @property
    def state_names(self):
        return tuple(f"joint {k + 1}" for k in range(7))

    def state_bounds(self):
        """The Panda's datasheet joint limits (the simulator clips every command to them), widened by
        :attr:`joint_margin`."""
        return panda.Q_MIN - self.joint_margin, panda.Q_MAX + self.joint_margin

    def reach_used(self, states, actions):
        delta = np.abs(np.asarray(actions, dtype=np.float64) - np.asarray(states, dtype=np.float64))
        return np.max(delta / (panda.VELOCITY_LIMIT * self.control_dt), axis=1)


BLOCK_REACH = BlockReachTask(
    name="block_reach",
    state_dim=7,
    space_dim=3,
    goal_low=np.array([0.3, -0.3, 0.1]),
    goal_high=np.array([0.7, 0.3, 0.1]),
    workspace_low=np.array([0.2, -0.55, 0.1]),
    workspace_high=np.array([0.9, 0.55, 0.1]),
    success_radius=0.035,
    step_size=0.01,
    min_goal_separation=0.06,
    control_dt=0.1,
    max_episode_steps=250,
    lateral_max=0.8,
    lateral_cap=0.3,
    lift_max=0.5,
    layouts=fixed_layouts(
        [
            [(0.5, -0.1), (0.5, 0.1)],
            [(0.55, -0.2), (0.55, -0.1)],
            [(0.55, 0.15), (0.58, 0.3)],
            [(0.5, -0.1), (0.65, 0.3)],
            [(0.4, -0.3), (0.6, 0.3)],
            [(0.4, 0.3), (0.4, -0.3)],
        ],
        z=0.1,
    ),
    ambiguous_layouts=(1, 2, 3),
    ambiguity=AmbiguitySettings(beta=4.0, tau=0.1963, kappa=0.99, eccentricity=0.88),
    viewer_eye=(1.7, 0.0, 1.05),  # across the table, 1.7 m in front of the base, eyes 1.05 m up
    viewer_target=(0.3, 0.0, 0.3),  # looking at the arm
)
