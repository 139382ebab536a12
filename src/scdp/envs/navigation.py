"""Navigation: a TurtleBot3 Burger drives to one of the goals in a room.

The robot is simulated kinematically as a differential drive. Each ``step`` takes the
absolute next pose, turns it into a twist with :func:`scdp.robots.turtlebot.track_pose`
(wheel-speed limited to 0.22 m/s and 2.84 rad/s) and integrates it exactly over
``task.control_dt`` seconds. The room walls clamp the position.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from matplotlib.patches import Circle

from scdp.drawing import draw_scene
from scdp.envs.base import GoalReachEnv
from scdp.robots import turtlebot


class NavigationEnv(GoalReachEnv):
    def build_action_space(self):
        lo = np.array([*self.task.workspace_low, -np.pi])
        hi = np.array([*self.task.workspace_high, np.pi])
        return spaces.Box(lo, hi, dtype=np.float64)

    def reset_robot(self, state):
        self._pose = np.array(state, dtype=np.float64)
        self.last_twist = (0.0, 0.0)

    @property
    def state(self):
        return self._pose

    def apply_action(self, action):
        dt = self.task.control_dt
        v, w = turtlebot.track_pose(self._pose, action, dt)
        pose = turtlebot.integrate(self._pose, v, w, dt)
        pose[:2] = np.clip(pose[:2], self.task.workspace_low, self.task.workspace_high)
        self._pose = pose
        self.last_twist = (v, w)

    def draw(self, fig):
        ax = fig.add_subplot(1, 1, 1)
        draw_scene(ax, self.task, self.goals, self.target)
        trail = np.array(self.trail)
        ax.plot(trail[:, 0], trail[:, 1], color="tab:blue", lw=1.5)
        x, y, th = self._pose
        ax.add_patch(Circle((x, y), turtlebot.BODY_RADIUS, fc="0.3", alpha=0.7))
        ax.arrow(x, y, 0.2 * np.cos(th), 0.2 * np.sin(th), width=0.02, color="k")
