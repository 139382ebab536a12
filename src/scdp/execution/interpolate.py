"""10 Hz joint waypoints -> 1 kHz jerk-limited joint samples, offline or chunk by chunk.

The policy plans one joint waypoint per ``step`` seconds (0.1 s for Block Reach); a Panda takes
a joint command every millisecond and refuses any whose velocity, acceleration or jerk is over
its limit. This module bridges the two with Ruckig, the jerk-limited online trajectory
generator used with libfranka and MoveIt 2 (why Ruckig: docs/deploy.md).

Each waypoint becomes one Ruckig target: reach ``w_i`` with the velocity the waypoints imply
there (their central difference, zero at the last one), no sooner than ``step`` seconds after
the previous one, within ``margin`` times the datasheet limits. A segment whose limits bind
takes longer: that is the time overhead over the 10 Hz schedule. Every segment starts from the
current position, velocity and acceleration, so a new chunk continues the motion without a
discontinuity (:class:`JerkLimitedStreamer`).

Shapes: waypoints (N, D); samples (M, D) at ``rate`` Hz. D = 7 for the Panda.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from ruckig import ControlInterface, DurationDiscretization, InputParameter, Result, Ruckig, Trajectory

from scdp.errors import ScdpError, finite_array
from scdp.robots import panda

KINDS = ("velocity", "acceleration", "jerk")


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits: positions (rad), and |velocity|, |acceleration|, |jerk| (rad/s^k)."""

    position_min: np.ndarray
    position_max: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray

    def scaled(self, margin: float) -> "JointLimits":
        """The same limits with velocity, acceleration and jerk times ``margin``."""
        return JointLimits(self.position_min, self.position_max, margin * self.velocity,
                           margin * self.acceleration, margin * self.jerk)


PANDA_LIMITS = JointLimits(panda.Q_MIN, panda.Q_MAX, panda.VELOCITY_LIMIT, panda.ACCELERATION_LIMIT, panda.JERK_LIMIT)


@dataclass
class Samples:
    """1 kHz output of one push: position, velocity, acceleration (M, D), and for each waypoint
    the index of the sample where it was reached (N,)."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    waypoint_index: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    def __len__(self) -> int:
        return len(self.position)


class JerkLimitedStreamer:
    """Stateful 1 kHz generator: :meth:`push` a chunk of waypoints, get the samples through them.

    The streamer keeps the position, velocity and acceleration of its last sample; the next push
    starts from there, so chunks planned one after another join with continuous velocity and
    acceleration (and jerk within its limit). ``margin`` scales the datasheet limits used for
    planning (0.9 leaves room for a real robot's tracking); checks use the full limits.
    """

    def __init__(self, start, *, step: float = 0.1, rate: float = 1000.0, limits: JointLimits = PANDA_LIMITS,
                 margin: float = 0.9):
        if not (np.isfinite(step) and step > 0):
            raise ScdpError("step", f"must be a positive number of seconds, got {step!r}")
        if not (np.isfinite(rate) and rate >= 1.0 / step):
            raise ScdpError("rate", f"must be at least one sample per step (>= {1.0 / step:g} Hz), got {rate!r}")
        if not 0 < margin <= 1:
            raise ScdpError("margin", f"must be in (0, 1], got {margin!r}")
        self.step, self.rate, self.limits = float(step), float(rate), limits
        self.dofs = len(limits.velocity)
        start = self._check_positions(np.atleast_2d(start), "start")[0]
        self._plan = limits.scaled(margin)
        self._otg = Ruckig(self.dofs, 1.0 / self.rate)
        self._inp = InputParameter(self.dofs)
        self._inp.current_position = start.tolist()
        self._inp.current_velocity = [0.0] * self.dofs
        self._inp.current_acceleration = [0.0] * self.dofs
        self._inp.max_velocity = self._plan.velocity.tolist()
        self._inp.max_acceleration = self._plan.acceleration.tolist()
        self._inp.max_jerk = self._plan.jerk.tolist()
        self._inp.min_position = limits.position_min.tolist()
        self._inp.max_position = limits.position_max.tolist()
        self._inp.duration_discretization = DurationDiscretization.Discrete  # segments end on a sample
        self._previous = start  # the last waypoint reached (for the velocity at the next one)

    @property
    def state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, velocity, acceleration) of the last sample, each (D,)."""
        return (np.array(self._inp.current_position), np.array(self._inp.current_velocity),
                np.array(self._inp.current_acceleration))

    def _check_positions(self, q: np.ndarray, name: str) -> np.ndarray:
        q = finite_array(q, name)
        if q.ndim != 2 or q.shape[1] != self.dofs:
            raise ScdpError(name, f"expected shape (N, {self.dofs}), got {q.shape}")
        tol = 1e-9
        bad = np.argwhere((q < self.limits.position_min - tol) | (q > self.limits.position_max + tol))
        if len(bad):
            i, j = bad[0]
            raise ScdpError(name, f"row {i} joint {j + 1} = {q[i, j]:.4f} rad is outside its limits "
                                  f"[{self.limits.position_min[j]}, {self.limits.position_max[j]}]")
        return q

    def waypoint_velocities(self, waypoints: np.ndarray, final: bool) -> np.ndarray:
        """Velocity to pass each waypoint with: the central difference of its neighbours (the
        previous one is the last waypoint reached), the backward difference at the end of a
        non-final chunk, zero at the end of a final one; clipped to the planning limits, and zero
        for a joint that could not stop before its range ends. (N, D)."""
        pts = np.vstack([self._previous, waypoints])
        v = np.empty_like(waypoints)
        v[:-1] = (pts[2:] - pts[:-2]) / (2 * self.step)
        v[-1] = 0.0 if final else (pts[-1] - pts[-2]) / self.step
        v = np.clip(v, -self._plan.velocity, self._plan.velocity)
        # never pass a waypoint so fast towards a joint limit that stopping would cross it
        a, j = self._plan.acceleration, self._plan.jerk
        stop = v**2 / (2 * a) + np.abs(v) * a / j
        beyond = np.where(v > 0, waypoints + stop > self.limits.position_max, waypoints - stop < self.limits.position_min)
        return np.where(beyond, 0.0, v)

    def push(self, waypoints, *, final: bool = False) -> Samples:
        """Move through ``waypoints`` (N, D) from the current state; return the 1 kHz samples.

        ``final=True`` comes to rest on the last waypoint; otherwise the motion passes it with
        the chunk's own velocity and the next push carries on from there.
        """
        waypoints = self._check_positions(np.atleast_2d(waypoints), "waypoints")
        velocities = self.waypoint_velocities(waypoints, final)
        pos, vel, acc, reached = [], [], [], []
        for i, (w, v) in enumerate(zip(waypoints, velocities)):
            self._segment(w, v, pos, vel, acc, i)
            reached.append(len(pos) - 1)
            self._previous = w
        return Samples(np.array(pos).reshape(-1, self.dofs), np.array(vel).reshape(-1, self.dofs),
                       np.array(acc).reshape(-1, self.dofs), np.array(reached, dtype=int))

    def _sampled(self, trajectory: Trajectory) -> tuple[list, list, list]:
        """``trajectory`` at the sample rate: (positions, velocities, accelerations), one per tick."""
        ticks = max(1, int(round(trajectory.duration * self.rate)))
        pos, vel, acc = [], [], []
        for k in range(1, ticks + 1):
            p, v, a = trajectory.at_time(k / self.rate)
            pos.append(p)
            vel.append(v)
            acc.append(a)
        return pos, vel, acc

    def _within_range(self, positions: list) -> bool:
        """Every sampled position inside the joint range. Checked on the samples a robot will get,
        not on Ruckig's ``position_extrema``: with discrete durations those were seen to miss
        overruns of up to 0.05 rad that the samples then held (issue 23's deploy test)."""
        q = np.asarray(positions)
        tol = 1e-7  # rad: Ruckig's own rounding on a waypoint that sits on a limit (seen: 7e-9)
        return bool(np.all(q >= self.limits.position_min - tol) and np.all(q <= self.limits.position_max + tol))

    def _segment(self, target, velocity, pos, vel, acc, index: int) -> None:
        """Samples from the current state to (target, velocity), at least ``step`` seconds long.

        If passing the waypoint with ``velocity`` would leave the joint range (or cannot be
        timed), the waypoint is reached at rest instead; if even that would overshoot the range
        (the motion so far heads for a limit too fast), the arm first brakes to rest, jerk-limited,
        then moves to the waypoint from rest. Only a brake that itself leaves the range is refused.
        """
        inp, trajectory = self._inp, Trajectory(self.dofs)
        inp.target_position = target.tolist()
        inp.target_acceleration = [0.0] * self.dofs
        inp.minimum_duration = self.step
        for attempt in (velocity, np.zeros_like(velocity)):
            inp.target_velocity = attempt.tolist()
            result = self._otg.calculate(inp, trajectory)
            if result in (Result.Working, Result.Finished):
                sampled = self._sampled(trajectory)
                if self._within_range(sampled[0]):
                    self._append(sampled, pos, vel, acc)
                    return
        if np.any(np.abs(inp.current_velocity) > 0) or np.any(np.abs(inp.current_acceleration) > 0):
            self._brake(pos, vel, acc, index)
            self._segment(target, np.zeros_like(velocity), pos, vel, acc, index)
            return
        raise ScdpError("waypoints", f"waypoint {index} cannot be reached within the joint limits from rest "
                                     f"(ruckig: {result.name})")

    def _brake(self, pos, vel, acc, index: int) -> None:
        """Come to rest from the current motion as fast as the planning limits allow."""
        inp, trajectory = self._inp, Trajectory(self.dofs)
        inp.control_interface = ControlInterface.Velocity
        inp.target_velocity, inp.target_acceleration = [0.0] * self.dofs, [0.0] * self.dofs
        inp.minimum_duration = None
        try:
            result = self._otg.calculate(inp, trajectory)
        finally:
            inp.control_interface = ControlInterface.Position
        sampled = self._sampled(trajectory) if result in (Result.Working, Result.Finished) else ([], [], [])
        if not sampled[0] or not self._within_range(sampled[0]):
            raise ScdpError("waypoints", f"waypoint {index} cannot be reached: the motion so far cannot stop "
                                         f"within the joint limits (ruckig: {result.name})")
        self._append(sampled, pos, vel, acc)
        inp.current_velocity, inp.current_acceleration = [0.0] * self.dofs, [0.0] * self.dofs  # at rest

    def _append(self, sampled: tuple[list, list, list], pos, vel, acc) -> None:
        """Append sampled (positions, velocities, accelerations); the streamer's state moves to their end."""
        pos += sampled[0]
        vel += sampled[1]
        acc += sampled[2]
        self._inp.current_position, self._inp.current_velocity, self._inp.current_acceleration = pos[-1], vel[-1], acc[-1]


def interpolate(waypoints, step: float = 0.1, rate: float = 1000) -> np.ndarray:
    """Panda joint waypoints (N, 7), one per ``step`` seconds, as joint positions at ``rate`` Hz (M, 7).

    The robot starts at rest on ``waypoints[0]`` and comes to rest on ``waypoints[-1]``; every
    sample respects the Panda's datasheet position, velocity, acceleration and jerk limits (planned
    at 0.9 of them). The first row is ``waypoints[0]``, the last ``waypoints[-1]``; M - 1 samples
    after the first span the trajectory's duration at ``1 / rate`` s each.
    """
    waypoints = finite_array(waypoints, "waypoints")
    if waypoints.ndim != 2 or waypoints.shape[1] != 7 or len(waypoints) < 1:
        raise ScdpError("waypoints", f"expected shape (N, 7) with N >= 1, got {waypoints.shape}")
    streamer = JerkLimitedStreamer(waypoints[0], step=step, rate=rate)
    if len(waypoints) == 1:
        return waypoints.copy()
    samples = streamer.push(waypoints[1:], final=True)
    return np.vstack([waypoints[:1], samples.position])


def limit_ratios(positions, rate: float = 1000.0, limits: JointLimits = PANDA_LIMITS, *, at_rest_before: bool = True) -> dict:
    """Worst |velocity|, |acceleration| and |jerk| over limit, by finite differences of (M, D) positions.

    Returns ``{"velocity": r_v, "acceleration": r_a, "jerk": r_j, "position": r_p}`` where each r
    is the largest ratio over samples and joints (1.0 = on the limit) and ``position`` is the
    largest overrun of the joint range in radians (0 inside). ``at_rest_before`` differentiates
    from a robot at rest on the first sample (as :func:`interpolate` starts), so a jump at the
    start counts.
    """
    q = finite_array(positions, "positions")
    if q.ndim != 2 or q.shape[1] != len(limits.velocity):
        raise ScdpError("positions", f"expected shape (M, {len(limits.velocity)}), got {q.shape}")
    if at_rest_before:
        q = np.vstack([np.repeat(q[:1], 3, axis=0), q])
    v = np.diff(q, axis=0) * rate
    a = np.diff(v, axis=0) * rate
    j = np.diff(a, axis=0) * rate
    worst = {kind: float(np.max(np.abs(d) / getattr(limits, kind), initial=0.0)) for kind, d in zip(KINDS, (v, a, j))}
    over = np.maximum(limits.position_min - q, q - limits.position_max)
    worst["position"] = float(max(np.max(over, initial=0.0), 0.0))
    return worst


def violations(ratios: dict, tol: float = 1e-6) -> list[str]:
    """Names of the limits a :func:`limit_ratios` result breaks (ratio above 1 + tol, or any overrun)."""
    broken = [k for k in KINDS if ratios[k] > 1.0 + tol]
    return broken + (["position"] if ratios["position"] > tol else [])
