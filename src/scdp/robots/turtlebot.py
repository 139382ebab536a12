"""TurtleBot3 Burger: differential-drive kinematics, datasheet limits and a pose tracker.

State is the pose ``(x, y, theta)``. The robot is driven by wheel speeds; a body twist
``(v, omega)`` maps to wheel rim speeds ``v -/+ omega * WHEEL_SEPARATION / 2``, and each
wheel is limited to the robot's top linear speed, so every command respects both
``|v| <= 0.22 m/s`` and ``|omega| <= 2.84 rad/s``.
"""

from __future__ import annotations

import numpy as np

MAX_LINEAR_SPEED = 0.22  # m/s
MAX_ANGULAR_SPEED = 2.84  # rad/s
WHEEL_SEPARATION = 0.160  # m
WHEEL_RADIUS = 0.033  # m
BODY_RADIUS = 0.105  # m, footprint for drawing


def wrap_angle(a):
    """Wrap angles to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def limit_twist(v: float, omega: float) -> tuple[float, float]:
    """Clip a body twist to the datasheet limits, scaling both wheels together.

    The twist is first clipped to ``|v| <= 0.22`` and ``|omega| <= 2.84``; if a wheel would
    still exceed 0.22 m/s, both wheel speeds are scaled by the same factor, which keeps
    the turning radius of the command.
    """
    v = float(np.clip(v, -MAX_LINEAR_SPEED, MAX_LINEAR_SPEED))
    omega = float(np.clip(omega, -MAX_ANGULAR_SPEED, MAX_ANGULAR_SPEED))
    half = omega * WHEEL_SEPARATION / 2
    worst = max(abs(v - half), abs(v + half))
    if worst > MAX_LINEAR_SPEED:
        s = MAX_LINEAR_SPEED / worst
        v, omega = v * s, omega * s
    return v, omega


def track_pose(pose, target, dt: float, lateral_gain: float = 5.0, max_correction: float = 0.5) -> tuple[float, float]:
    """Twist that moves ``pose`` onto the absolute ``target`` pose within one period ``dt``.

    The robot drives the part of the position error that lies along its heading
    (``v = e_x / dt``) and turns towards the *commanded heading*, corrected by
    ``lateral_gain * e_y`` radians (capped at ``max_correction``) for the sideways error.
    Following the commanded heading, rather than the direction to the point, keeps a
    learned policy's small position noise from steering the robot. The result is limited by
    :func:`limit_twist`.
    """
    x, y, th = pose
    dx, dy = target[0] - x, target[1] - y
    ex = np.cos(th) * dx + np.sin(th) * dy
    ey = -np.sin(th) * dx + np.cos(th) * dy
    correction = float(np.clip(lateral_gain * ey, -max_correction, max_correction)) * (1.0 if ex >= 0 else -1.0)
    heading_err = float(wrap_angle(target[2] + correction - th))
    return limit_twist(ex / dt, heading_err / dt)


def integrate(pose, v: float, omega: float, dt: float) -> np.ndarray:
    """Exact unicycle motion under a constant twist ``(v, omega)`` held for ``dt`` seconds.

    The heading is not wrapped, so it stays continuous along an episode (a policy that
    predicts absolute headings never sees a jump at +-pi).
    """
    x, y, th = (float(p) for p in pose)
    if abs(omega) > 1e-9:
        x += v / omega * (np.sin(th + omega * dt) - np.sin(th))
        y -= v / omega * (np.cos(th + omega * dt) - np.cos(th))
    else:
        x += v * dt * np.cos(th)
        y += v * dt * np.sin(th)
    return np.array([x, y, th + omega * dt])  # heading kept unwrapped: continuous for learning
