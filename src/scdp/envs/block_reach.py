"""Block Reach: a MuJoCo Panda reaches one of the blocks on a table.

The model is written by :func:`scdp.robots.panda.mjcf` from the datasheet DH table. Each
``step`` takes the absolute next joint positions and clips them to the joint limits and to
what the velocity limits allow in one period. How the arm then gets there is ``tracking``:

* ``"exact"`` (the default): the arm is at the clipped command after ``task.control_dt``,
  with the mean velocity of the step. This is what the deployed arm does: the 1 kHz
  jerk-limited execution of :mod:`scdp.execution` on the torque-controlled Panda tracks its
  waypoints to a fraction of a millirad (``results/benchmarks/execution_1khz.json``), so
  demonstrations recorded here and policies run here see the states a real arm reports.
* ``"servo"``: the command becomes a MuJoCo position-servo target and the dynamics run for
  ``task.control_dt`` seconds; the state trails every command by a few per cent of the step.
  A policy trained on servo-lagged demonstrations learns that lag and misses its goals when
  executed on an arm that tracks exactly (``results/deploy/reference.json``).
"""

from __future__ import annotations

import mujoco
import numpy as np
from gymnasium import spaces

from scdp.drawing import NEGATIVE_COLOR, TARGET_COLOR, draw_scene
from scdp.envs.base import EnvTask, GoalReachEnv
from scdp.errors import ScdpError
from scdp.robots import panda

TRACKING = ("exact", "servo")


class BlockReachEnv(GoalReachEnv):
    def __init__(self, task: EnvTask, *, tracking: str = "exact", **kwargs):
        if tracking not in TRACKING:
            raise ValueError(f"tracking must be one of {', '.join(TRACKING)}, got {tracking!r}")
        self.tracking = tracking
        super().__init__(task, **kwargs)
        self.model = panda.model(blocks=self.n_goals, shared=True)  # never changed here: see own_model
        self.data = mujoco.MjData(self.model)
        self._shared = True  # self.model is the process's compiled model, until own_model copies it
        self._substeps = max(1, round(task.control_dt / self.model.opt.timestep))
        self._max_dq = panda.VELOCITY_LIMIT * task.control_dt

    def build_action_space(self):
        return spaces.Box(panda.Q_MIN, panda.Q_MAX, dtype=np.float64)

    def reset_robot(self, state):
        if self.model.nmocap < len(self.goals):
            self.model = panda.model(blocks=len(self.goals), shared=True)
            self.data = mujoco.MjData(self.model)
            self._shared = True
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:7] = state
        self.data.ctrl[:] = state
        for k in range(self.model.nmocap):
            # Unused blocks are parked under the floor.
            self.data.mocap_pos[k] = self.goals[k] if k < len(self.goals) else (0.0, 0.0, -1.0)
        mujoco.mj_forward(self.model, self.data)

    def own_model(self) -> mujoco.MjModel:
        """This environment's model as a copy of its own, for a caller that changes it (the blocks'
        colours, the camera): environments share one compiled model until then. The state is kept."""
        if self._shared:
            state = mujoco.MjData(self.model)
            mujoco.mj_copyData(state, self.model, self.data)
            self.model = panda.model(blocks=self.model.nmocap)
            self.data = mujoco.MjData(self.model)
            mujoco.mj_copyData(self.data, self.model, state)
            self._shared = False
        return self.model

    def place_goals(self):
        if len(self.goals) > self.model.nmocap:
            raise ScdpError("goals", f"this scene's model holds {self.model.nmocap} blocks, got {len(self.goals)}: "
                                     "reset with the most goals the episode will hold")
        for k in range(self.model.nmocap):
            self.data.mocap_pos[k] = self.goals[k] if k < len(self.goals) else (0.0, 0.0, -1.0)
        mujoco.mj_forward(self.model, self.data)

    @property
    def state(self):
        return self.data.qpos[:7].copy()

    @property
    def position(self):
        return self.data.site("tcp").xpos.copy()

    def apply_action(self, action):
        q = self.data.qpos[:7]
        target = np.clip(np.clip(action, q - self._max_dq, q + self._max_dq), panda.Q_MIN, panda.Q_MAX)
        self.data.ctrl[:] = target
        if self.tracking == "servo":
            mujoco.mj_step(self.model, self.data, nstep=self._substeps)
            return
        self.data.qvel[:7] = (target - q) / self.task.control_dt
        self.data.qpos[:7] = target
        self.data.time += self.task.control_dt
        mujoco.mj_forward(self.model, self.data)

    def draw(self, fig):
        frames = panda.joint_frames(self.state)
        chain = np.vstack([[0, 0, 0], frames[:, :3, 3], self.position])
        trail = np.array(self.trail)
        top, side = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
        draw_scene(top, self.task, self.goals, self.target)
        top.plot(chain[:, 0], chain[:, 1], "o-", color="0.3", lw=3, ms=3)
        top.plot(trail[:, 0], trail[:, 1], color="tab:blue")
        side.plot(chain[:, 0], chain[:, 2], "o-", color="0.3", lw=3, ms=3)
        side.plot(trail[:, 0], trail[:, 2], color="tab:blue")
        side.scatter(self.goals[:, 0], self.goals[:, 2],
                     c=[TARGET_COLOR if k == self.target else NEGATIVE_COLOR for k in range(len(self.goals))], marker="s")
        side.set(xlabel="x [m]", ylabel="z [m]", title="side view", aspect="equal")
