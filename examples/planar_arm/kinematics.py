"""A planar 3-link arm: link lengths, limits, forward kinematics, Jacobian and IK in one place.

The base sits at the origin and every joint turns about the z axis, so the arm moves in the
x-y plane. Joint ``i`` adds ``q_i`` to the heading of link ``i``: link ``i`` points along
``q_1 + ... + q_i`` (radians, counter-clockwise from +x).

Shapes: ``q`` is ``(..., 3)`` joint angles in radians; points are ``(..., 2)`` in metres.
"""

from __future__ import annotations

import numpy as np

from scdp.robots.ik import solve_point_ik

LINKS = np.array([0.40, 0.35, 0.25])  # m, shoulder -> elbow -> wrist -> end effector; 1.0 m at full stretch
Q_MIN = np.full(3, -2.8)  # rad, every joint: short of a full fold back onto the previous link
Q_MAX = np.full(3, 2.8)
SPEED_LIMIT = np.full(3, 1.5)  # rad/s per joint
TUCKED = np.array([1.40, -1.90, -1.60])  # rad: folded, the end effector near (0.25, 0), pointing down and back
REACH = float(LINKS.sum())  # m, the farthest the end effector gets from the base
REACH_MARGIN = 0.05  # m short of full stretch: beyond it the Jacobian is near singular and IK crawls
MIN_RADIUS = 0.15  # m from the base: nearer goals leave the arm folded up tight, close to its joint limits


def joint_points(q) -> np.ndarray:
    """Base, elbow, wrist and end effector: (..., 3) -> (..., 4, 2), metres."""
    q = np.asarray(q, dtype=np.float64)
    heading = np.cumsum(q, axis=-1)  # (..., 3) heading of each link
    links = LINKS[:, None] * np.stack([np.cos(heading), np.sin(heading)], axis=-1)  # (..., 3, 2)
    points = np.cumsum(links, axis=-2)  # (..., 3, 2): elbow, wrist, end effector
    base = np.zeros(points.shape[:-2] + (1, 2))
    return np.concatenate([base, points], axis=-2)


def end_effector(q) -> np.ndarray:
    """Forward kinematics: (..., 3) joint angles -> (..., 2) end-effector point, metres."""
    return joint_points(q)[..., -1, :]


def jacobian(q) -> np.ndarray:
    """d end_effector / d q at one configuration: (3,) -> (2, 3), metres per radian.

    Joint ``i`` turns everything after it about its own axis, so its column is the
    end effector's offset from joint ``i`` rotated by 90 degrees: ``(-dy, dx)``.
    """
    points = joint_points(q)
    offset = points[-1] - points[:3]  # (3, 2): joint -> end effector
    return np.stack([-offset[:, 1], offset[:, 0]])


def solve_ik(target, q_init, *, q_rest=TUCKED, damping: float = 0.02, posture_gain: float = 0.05,
             max_step: float = 0.2, tol: float = 5e-4, max_iters: int = 200) -> tuple[np.ndarray, bool]:
    """Damped-least-squares IK for the end-effector point, warm-started at ``q_init``.

    Each iteration takes ``dq = J^T (J J^T + damping^2 I)^-1 e`` for the position error ``e``
    (2,), plus ``posture_gain * (q_rest - q)`` projected into the Jacobian's null space (the
    arm has one joint more than the plane needs), scaled so no joint moves more than
    ``max_step`` rad, then clipped to the joint limits. Returns ``(q (3,), converged)``, where
    ``converged`` means the end effector is within ``tol`` metres of ``target``.
    """
    return solve_point_ik(target, q_init, point=end_effector, jacobian=jacobian, q_rest=q_rest, q_min=Q_MIN,
                          q_max=Q_MAX, damping=damping, posture_gain=posture_gain, max_step=max_step, tol=tol,
                          max_iters=max_iters)


def reachable(points) -> np.ndarray:
    """Which task-space points (..., 2) the arm reaches comfortably: (...,) booleans."""
    r = np.linalg.norm(np.asarray(points, dtype=np.float64), axis=-1)
    return (r >= MIN_RADIUS) & (r <= REACH - REACH_MARGIN)
