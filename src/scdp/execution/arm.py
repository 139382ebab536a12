"""The arm that executes 1 kHz joint samples: the :class:`Arm` protocol and a simulated Panda.

A real robot plugs in by implementing :class:`Arm`, two methods. With libfranka, ``follow``
runs a joint-position motion generator (``robot.control(callback)``) whose callback returns
``samples.position[i]`` at tick ``i`` and records ``RobotState.q``; ``joint_positions`` reads
``robot.readOnce().q``. libfranka checks the same velocity, acceleration and jerk limits that
:func:`scdp.execution.interpolate.limit_ratios` checks here.

:class:`SimulatedPanda` is the MuJoCo Panda (:func:`scdp.robots.panda.mjcf`) stepped every
millisecond under joint torque control: computed torque (MuJoCo's inverse dynamics, which
includes gravity) for the commanded acceleration plus PD feedback on the commanded position
and velocity, clipped to the datasheet torques.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import mujoco
import numpy as np

from scdp.errors import ScdpError, finite_array
from scdp.execution.interpolate import Samples
from scdp.robots import panda


@runtime_checkable
class Arm(Protocol):
    def joint_positions(self) -> np.ndarray:
        """Measured joint positions now, (7,)."""
        ...

    def follow(self, samples: Samples) -> np.ndarray:
        """Execute the 1 kHz samples in real time; return the measured joint positions (M, 7),
        one per sample, after it was commanded."""
        ...


class SimulatedPanda:
    """A MuJoCo Panda with the Block Reach blocks, at ``rate`` Hz under computed-torque control.

    Also a render target for :func:`scdp.perception.render.render_rgbd` (it has ``model`` and
    ``data``). ``kp`` (1/s^2) and ``kd`` (1/s) set the feedback's stiffness and damping per
    unit of inertia (critically damped at the defaults).
    """

    CONTROLS = ("torque", "position")

    def __init__(self, goals, start=panda.READY_POSE, *, rate: float = 1000.0, control: str = "torque", kp: float = 400.0,
                 kd: float = 40.0):
        goals = finite_array(goals, "goals", (3,))
        if control not in self.CONTROLS:
            raise ScdpError("control", f"unknown control {control!r} (choose from {', '.join(self.CONTROLS)})")
        self.control = control
        actuators = "motor" if control == "torque" else "position"
        self.model = panda.model(blocks=len(goals), timestep=1.0 / rate, actuators=actuators)
        self.data = mujoco.MjData(self.model)
        self.rate, self.kp, self.kd = float(rate), float(kp), float(kd)
        self.data.mocap_pos[:] = goals
        self.data.qpos[:7] = finite_array(start, "start", (7,))
        mujoco.mj_forward(self.model, self.data)

    def joint_positions(self) -> np.ndarray:
        return self.data.qpos[:7].copy()

    def tcp(self) -> np.ndarray:
        return self.data.site("tcp").xpos.copy()

    def follow(self, samples: Samples) -> np.ndarray:
        m, d = self.model, self.data
        measured = np.empty_like(samples.position)
        for i, (q, qd, qdd) in enumerate(zip(samples.position, samples.velocity, samples.acceleration)):
            if self.control == "torque":
                d.qacc[:7] = qdd + self.kp * (q - d.qpos[:7]) + self.kd * (qd - d.qvel[:7])
                mujoco.mj_inverse(m, d)
                d.ctrl[:] = np.clip(d.qfrc_inverse[:7], -panda.TORQUE_LIMIT, panda.TORQUE_LIMIT)
            else:
                d.ctrl[:] = q
            mujoco.mj_step(m, d)
            if not np.all(np.isfinite(d.qpos[:7])):
                raise ScdpError("simulation", f"the simulated arm diverged at sample {i}")
            measured[i] = d.qpos[:7]
        return measured


def tracking_error(commanded: np.ndarray, measured: np.ndarray) -> dict:
    """Worst joint error (rad) and TCP distance (m) between commanded and measured (M, 7) positions."""
    joint = float(np.max(np.abs(commanded - measured), initial=0.0))
    tcp = float(np.max(np.linalg.norm(panda.tcp_position(commanded) - panda.tcp_position(measured), axis=-1), initial=0.0))
    return {"joint_rad": joint, "tcp_m": tcp}
