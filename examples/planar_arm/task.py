"""Planar Arm: a 3-link arm in the x-y plane reaching one of the goals in front of it.

A task defined outside the library, as docs/tasks.md describes. State: the 3 joint angles (rad).
Task space: the end effector's (x, y), metres, in the frame of the arm's base. Actions: the
absolute next joint angles, as for every scdp task.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scdp.ambiguity import AmbiguitySettings
from scdp.errors import ScdpError
from scdp.tasks import Task
from scdp.tasks.base import fixed_layouts, follow_path

from . import kinematics as kin
from .env import PlanarArmEnv


@dataclass(frozen=True, eq=False)
class PlanarArmTask(Task):
    """A 3-link planar arm starting tucked, its end effector near (0.25, 0)."""

    def task_space(self, states) -> np.ndarray:
        return kin.end_effector(states)  # (..., 3) rad -> (..., 2) m

    def nominal_start(self) -> np.ndarray:
        return kin.TUCKED.copy()  # (3,) rad

    def actions_for_path(self, path, start_state):
        """Damped-least-squares IK at every point of ``path`` (K, 2), each solve warm-started from the
        previous solution. (K - 1, 3) joint angles, or None when a point is missed by more than
        0.5 mm, would need a joint past its limit, or a step beyond the arm's one-step reach."""
        out = follow_path(path, start_state, lambda point, q: kin.solve_ik(point, q, tol=5e-4))  # within the joint limits
        if out is None:
            return None
        previous = np.vstack([np.asarray(start_state, dtype=np.float64)[None], out[:-1]])
        if np.any(self.reach_used(previous, out) > 1.0):
            return None
        return out

    def check_reachable(self, goals, field):
        radius = np.linalg.norm(goals, axis=1)  # (n,) m from the base
        bad = ~kin.reachable(goals)
        if bad.any():
            k = int(np.argmax(bad))
            raise ScdpError(field, f"goal {k} {np.round(goals[k], 4).tolist()} is {radius[k]:.3f} m from the arm's base; "
                                   f"the arm reaches {kin.MIN_RADIUS}..{kin.REACH - kin.REACH_MARGIN:.2f} m")

    def make_env(self, **kwargs):
        return PlanarArmEnv(self, **kwargs)

    joint_margin = 0.05  # rad beyond the joint limits a reported angle may lie (encoder noise)

    @property
    def state_names(self):
        return ("shoulder", "elbow", "wrist")

    def state_bounds(self):
        """The joint limits (the environment clips every command to them), widened by :attr:`joint_margin`."""
        return kin.Q_MIN - self.joint_margin, kin.Q_MAX + self.joint_margin

    def reach_used(self, states, actions):
        """(T, 3) states and actions -> (T,): the largest joint move over what it can do in one period."""
        delta = np.abs(np.asarray(actions, dtype=np.float64) - np.asarray(states, dtype=np.float64))
        return np.max(delta / (kin.SPEED_LIMIT * self.control_dt), axis=1)


PLANAR_ARM = PlanarArmTask(
    name="planar_arm",
    state_dim=3,
    space_dim=2,
    goal_low=np.array([0.45, -0.35]),  # in front of the arm: 0.45..0.83 m from the base, all reachable
    goal_high=np.array([0.75, 0.35]),
    workspace_low=np.array([0.3, -0.5]),  # its far corners lie beyond reach: check_reachable refuses them
    workspace_high=np.array([0.85, 0.5]),
    success_radius=0.03,
    step_size=0.01,  # 1 cm per recorded state: demos use under a fifth of the one-step reach (reach_used <= 0.18)
    min_goal_separation=0.06,  # twice the success radius: no point is inside two goals' radii
    control_dt=0.1,  # s: one-step reach 1.5 rad/s x 0.1 s = 0.15 rad per joint
    max_episode_steps=150,  # over twice the longest demo (67 steps in 500 generated with seed 0)
    lateral_max=0.8,
    lateral_cap=0.25,  # m: a bend of up to ~12 cm, keeping paths between the base and the arm's reach
    lift_max=0.0,  # a planar task
    layouts=fixed_layouts(
        [
            [(0.60, 0.05), (0.60, -0.05)],  # close together, straight ahead
            [(0.55, -0.15), (0.62, -0.20)],  # one behind the other, to the right
            [(0.70, 0.10), (0.66, 0.19)],  # close together, to the left
            [(0.55, 0.30), (0.55, -0.30)],  # far apart
            [(0.70, 0.25), (0.70, -0.25)],
            [(0.50, -0.30), (0.72, 0.28)],
        ]
    ),
    ambiguous_layouts=(1, 2, 3),
    # from `scdp ambiguity-report --task examples.planar_arm:TASK --scenes 10000 --seed 0` (beta 4 as the
    # built-in tasks): tau splits the twelve labelled scenes (margins <= 0.061 vs >= 0.379), the ellipse
    # matches every label and agrees with eq. 3 on 82.2 % of random scenes
    ambiguity=AmbiguitySettings(beta=4.0, tau=0.2198, kappa=0.99, eccentricity=0.86),
    start_noise=np.full(3, 0.01),  # rad per joint: 2.5-4 mm at the end effector per joint and standard deviation
)
TASK = PLANAR_ARM
