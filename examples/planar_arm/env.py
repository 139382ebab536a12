"""The planar arm's Gymnasium environment: kinematic, no physics engine.

Each ``step`` takes the absolute next joint angles (3,), moves every joint toward them by at
most ``SPEED_LIMIT * task.control_dt`` radians (the arm's one-step reach) and clips the result to
the joint limits. The arm is then exactly there: an ideal position-controlled arm.
Observations, rewards, success and truncation come from :class:`scdp.envs.base.GoalReachEnv`.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from scdp.drawing import draw_scene
from scdp.envs.base import GoalReachEnv

from . import kinematics as kin


class PlanarArmEnv(GoalReachEnv):
    """A 3-link arm in the x-y plane reaching one of the goals. State: 3 joint angles (rad)."""

    def build_action_space(self):
        return spaces.Box(kin.Q_MIN, kin.Q_MAX, dtype=np.float64)

    def reset_robot(self, state):
        self._q = np.clip(np.array(state, dtype=np.float64), kin.Q_MIN, kin.Q_MAX)

    @property
    def state(self):
        return self._q

    def apply_action(self, action):
        reach = kin.SPEED_LIMIT * self.task.control_dt  # (3,) rad per step
        move = np.clip(np.asarray(action, dtype=np.float64) - self._q, -reach, reach)
        self._q = np.clip(self._q + move, kin.Q_MIN, kin.Q_MAX)

    def draw(self, fig):
        ax = fig.add_subplot(1, 1, 1)
        draw_scene(ax, self.task, self.goals, self.target)
        trail = np.array(self.trail)  # (t, 2) end-effector points so far
        ax.plot(trail[:, 0], trail[:, 1], color="tab:blue", lw=1.5)
        arm = kin.joint_points(self._q)  # (4, 2): base, elbow, wrist, end effector
        ax.plot(arm[:, 0], arm[:, 1], "-o", color="0.3", lw=4, ms=5, solid_capstyle="round", zorder=1)  # under the markers
        ax.plot(0.0, 0.0, "ks", ms=10)  # the base
        ax.set(xlim=(-0.3, 1.05), ylim=(-0.6, 0.6))
