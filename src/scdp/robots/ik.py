"""Damped-least-squares inverse kinematics for a point, with a posture term in the null space: the
one solver behind every arm (the Panda's TCP, an arm of your own; docs/tasks.md).

Each iteration solves ``dq = J^T (J J^T + damping^2 I)^-1 e`` for the point's error ``e`` (d,)
and adds ``posture_gain * (q_rest - q)`` projected into the Jacobian's null space, so a redundant
arm's spare joints stay near the rest posture; the step is scaled so no joint moves more than
``max_step`` rad, and the joints are clipped to ``[q_min, q_max]`` after every step.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def solve_point_ik(target, q_init, *, point: Callable[[np.ndarray], np.ndarray],
                   jacobian: Callable[[np.ndarray], np.ndarray], q_rest, q_min, q_max, damping: float,
                   posture_gain: float, max_step: float, tol: float, max_iters: int) -> tuple[np.ndarray, bool]:
    """Joints (n,) that put ``point(q)`` (d,) at ``target`` (d,), from ``q_init``; ``jacobian(q)``
    is (d, n). Returns ``(q, converged)``, ``converged`` meaning ``|point(q) - target| < tol``."""
    target = np.asarray(target, dtype=np.float64)
    q = np.clip(np.array(q_init, dtype=np.float64), q_min, q_max)
    eye_d, eye_n = np.eye(len(target)), np.eye(len(q))
    for _ in range(max_iters):
        err = target - point(q)
        if np.linalg.norm(err) < tol:
            return q, True
        J = jacobian(q)
        J_pinv = J.T @ np.linalg.inv(J @ J.T + damping**2 * eye_d)  # (n, d)
        dq = J_pinv @ err + (eye_n - J_pinv @ J) @ (posture_gain * (q_rest - q))
        scale = np.max(np.abs(dq)) / max_step
        if scale > 1.0:
            dq = dq / scale
        q = np.clip(q + dq, q_min, q_max)
    return q, bool(np.linalg.norm(target - point(q)) < tol)
