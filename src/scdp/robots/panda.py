"""Franka Emika Panda: published kinematics, limits, FK, IK and a MuJoCo model.

Every number here is from Franka's datasheet (modified DH, Craig convention):
joint ``i`` is reached from frame ``i-1`` by ``RotX(alpha) TransX(a) RotZ(q_i) TransZ(d)``;
the eighth row is the flange (no joint). The TCP of the Franka Hand sits
0.1034 m along the flange z axis.

Shapes: ``q`` is ``(..., 7)``; positions are ``(..., 3)``; transforms ``(..., 4, 4)``.
"""

from __future__ import annotations

import copy
from functools import lru_cache

import mujoco
import numpy as np

from scdp.errors import ScdpError, finite_array
from scdp.robots import panda_meshes
from scdp.robots.ik import solve_point_ik

DH_A = np.array([0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088, 0.0])
DH_D = np.array([0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0, 0.107])
DH_ALPHA = np.array([0.0, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2, 0.0])
TCP_OFFSET = 0.1034

Q_MIN = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
Q_MAX = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
VELOCITY_LIMIT = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])
ACCELERATION_LIMIT = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])
JERK_LIMIT = np.array([7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0])
TORQUE_LIMIT = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0])
CARTESIAN_SPEED_LIMIT = 1.7  # m/s at the TCP
CONTROL_RATE_HZ = 1000.0
READY_POSE = np.array([0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4])
BLOCK_HALF_SIZE = 0.025  # the blocks are 5 cm cubes; a goal is a block's centre
SHOULDER = np.array([0.0, 0.0, 0.333])  # joint 2 axis crosses here; reach is measured from it


def _dh_transform(a, d, alpha, theta) -> np.ndarray:
    """Craig's modified-DH transform, broadcast over ``theta`` of shape (...). Returns (..., 4, 4)."""
    theta = np.asarray(theta, dtype=np.float64)
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    T = np.zeros(theta.shape + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 3] = ct, -st, a
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st * ca, ct * ca, -sa, -sa * d
    T[..., 2, 0], T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = st * sa, ct * sa, ca, ca * d
    T[..., 3, 3] = 1.0
    return T


def joint_frames(q) -> np.ndarray:
    """Base-to-frame transforms of joints 1..7 and the flange. (..., 7) -> (..., 8, 4, 4)."""
    q = np.asarray(q, dtype=np.float64)
    thetas = np.concatenate([q, np.zeros(q.shape[:-1] + (1,))], axis=-1)
    frames = []
    T = np.broadcast_to(np.eye(4), q.shape[:-1] + (4, 4))
    for i in range(8):
        T = T @ _dh_transform(DH_A[i], DH_D[i], DH_ALPHA[i], thetas[..., i])
        frames.append(T)
    return np.stack(frames, axis=-3)


def flange_pose(q) -> np.ndarray:
    """Base-to-flange homogeneous transform. (..., 7) -> (..., 4, 4)."""
    return joint_frames(q)[..., -1, :, :]


def tcp_position(q) -> np.ndarray:
    """Franka Hand TCP position in the base frame. (..., 7) -> (..., 3)."""
    F = flange_pose(q)
    return F[..., :3, 3] + TCP_OFFSET * F[..., :3, 2]


def tcp_jacobian(q) -> np.ndarray:
    """Positional Jacobian of the TCP, d tcp / d q. (7,) -> (3, 7)."""
    frames = joint_frames(q)
    p = frames[-1, :3, 3] + TCP_OFFSET * frames[-1, :3, 2]
    z = frames[:7, :3, 2]
    origins = frames[:7, :3, 3]
    return np.cross(z, p - origins).T


def solve_ik(
    target,
    q_init=READY_POSE,
    *,
    q_rest=READY_POSE,
    damping: float = 0.02,
    posture_gain: float = 0.05,
    max_step: float = 0.2,
    tol: float = 1e-4,
    max_iters: int = 200,
) -> tuple[np.ndarray, bool]:
    """Damped-least-squares IK for the TCP position, with a posture term in the nullspace.

    Each iteration solves ``dq = J^T (J J^T + damping^2 I)^-1 e`` for the position error
    ``e`` and adds ``posture_gain * (q_rest - q)`` projected into the Jacobian's nullspace,
    so the redundant 7th degree of freedom stays near the ready posture. Joints are clipped
    to their limits after every step.

    Returns ``(q, converged)`` where ``converged`` means ``|tcp(q) - target| < tol``.
    """
    return solve_point_ik(target, q_init, point=tcp_position, jacobian=tcp_jacobian, q_rest=q_rest, q_min=Q_MIN,
                          q_max=Q_MAX, damping=damping, posture_gain=posture_gain, max_step=max_step, tol=tol,
                          max_iters=max_iters)


def inverse_kinematics(target, q_init=READY_POSE, *, field: str = "target", tol: float = 1e-3) -> np.ndarray:
    """Like :func:`solve_ik` but raises :class:`ScdpError` naming ``field`` when unreachable."""
    target = finite_array(target, field, (3,))
    q, ok = solve_ik(target, q_init, tol=tol)
    if not ok:
        # A second try from the ready pose rescues starts that sit in a poor branch.
        q, ok = solve_ik(target, READY_POSE, tol=tol)
    if not ok:
        raise ScdpError(field, f"{np.round(target, 4).tolist()} is beyond the Panda's reach")
    return q


# ---------------------------------------------------------------------------------------
# MuJoCo model, written from the DH table above.

_LINK_MASS = [4.0, 4.0, 3.0, 3.0, 3.0, 1.5, 0.8, 0.7]  # rough, for a stable simulation only
_LINK_RADIUS = [0.06, 0.06, 0.055, 0.055, 0.05, 0.045, 0.04, 0.035]
_KP = [4500.0, 4500.0, 3500.0, 3500.0, 2000.0, 2000.0, 2000.0]
_KV = [200.0, 200.0, 150.0, 150.0, 80.0, 80.0, 80.0]  # tracks 1 cm steps within 1 mm


def _quat_x(angle: float) -> str:
    return f"{np.cos(angle / 2):.10f} {np.sin(angle / 2):.10f} 0 0"


ACTUATORS = ("position", "motor")
CAMERA_NAME = "rgbd"  # a fixed camera; scdp.perception.render_rgbd places it from a calibration
MAX_IMAGE_SIZE = (1920, 1080)  # offscreen buffer: the largest camera image that can be rendered
SHADOW_SIZE = 1024  # shadow map texels (MuJoCo's default 4096 costs 3x the frame on a software renderer)


def mjcf(blocks: int = 2, table_height: float = 0.075, timestep: float = 0.002, actuators: str = "position",
         meshes: bool | None = None) -> str:
    """MJCF text for a Panda on a table with ``blocks`` mocap blocks, a TCP site and a camera.

    Each DH row becomes a body placed at ``TransX(a) RotX(alpha) TransZ(d)`` from its parent,
    with a hinge about the body's own z axis, so MuJoCo's kinematics equal :func:`joint_frames`.
    Links are capsules to the next joint origin (their masses drive the dynamics); bodies use
    gravity compensation. With ``meshes`` (None: when installed, see :mod:`scdp.robots.panda_meshes`)
    the arm is drawn with Franka's meshes on the same frames, massless, and the capsules move to a
    hidden geom group; the dynamics are the same either way. ``actuators`` is ``"position"``
    (position servos, the 10 Hz environments) or ``"motor"`` (joint torques, for 1 kHz torque
    control in :mod:`scdp.execution`), both within the datasheet torque limits. The arm does not
    collide (reaching task only). Blocks are 5 cm cubes.
    """
    if actuators not in ACTUATORS:
        raise ScdpError("actuators", f"unknown kind {actuators!r} (choose from {', '.join(ACTUATORS)})")
    folder = panda_meshes.mesh_folder()
    if meshes and folder is None:
        raise ScdpError("meshes", f"the Panda's meshes are not installed: {panda_meshes.mesh_source()}")
    folder = folder if meshes is not False else None
    capsule_group = f' group="{panda_meshes.HIDDEN_GROUP}"' if folder else ""
    bodies = []
    for i in range(8):
        a, d, al = DH_A[i], DH_D[i], DH_ALPHA[i]
        pos = (a, -np.sin(al) * d, np.cos(al) * d)
        name = f"link{i + 1}" if i < 7 else "flange"
        inner = f'<body name="{name}" pos="{pos[0]:.10f} {pos[1]:.10f} {pos[2]:.10f}" quat="{_quat_x(al)}" gravcomp="1">'
        if i < 7:
            inner += (
                f'<joint name="joint{i + 1}" axis="0 0 1" range="{Q_MIN[i]} {Q_MAX[i]}" '
                f'damping="1" armature="0.1" actuatorfrcrange="{-TORQUE_LIMIT[i]} {TORQUE_LIMIT[i]}"/>'
            )
        # Capsule from this frame's origin to the next frame's origin (expressed locally).
        if i < 7:
            na, nd, nal = DH_A[i + 1], DH_D[i + 1], DH_ALPHA[i + 1]
            nxt = np.array([na, -np.sin(nal) * nd, np.cos(nal) * nd])
        else:
            nxt = np.array([0.0, 0.0, TCP_OFFSET])
        if np.linalg.norm(nxt) > 1e-6:
            geom = f'fromto="0 0 0 {nxt[0]:.10f} {nxt[1]:.10f} {nxt[2]:.10f}" type="capsule"'
        else:
            geom = 'type="sphere"'
        inner += f'<geom {geom} size="{_LINK_RADIUS[i]}" mass="{_LINK_MASS[i]}" rgba="0.92 0.92 0.95 1"{capsule_group}/>'
        if folder:
            inner += panda_meshes.link_geom(name) if i < 7 else panda_meshes.hand_geoms()
        if i == 7:
            inner += f'<site name="tcp" pos="0 0 {TCP_OFFSET}" size="0.01" rgba="1 0 0 1"/>'
        bodies.append(inner)
    chain = "".join(bodies) + "</body>" * 8
    colors = ["0.2 0.4 0.9 1", "0.9 0.3 0.6 1", "0.3 0.8 0.3 1", "0.9 0.7 0.2 1", "0.6 0.3 0.9 1"]
    block_xml = "".join(
        f'<body name="block{k}" mocap="true" pos="0.5 {0.1 * k} 0.1">'
        f'<geom name="block{k}" type="box" size="{BLOCK_HALF_SIZE} {BLOCK_HALF_SIZE} {BLOCK_HALF_SIZE}" '
        f'rgba="{colors[k % len(colors)]}" contype="0" conaffinity="0"/></body>'
        for k in range(blocks)
    )
    if actuators == "position":
        actuator_xml = "".join(
            f'<position name="act{i + 1}" joint="joint{i + 1}" kp="{_KP[i]}" kv="{_KV[i]}" '
            f'ctrlrange="{Q_MIN[i]} {Q_MAX[i]}"/>'
            for i in range(7)
        )
    else:
        actuator_xml = "".join(
            f'<motor name="act{i + 1}" joint="joint{i + 1}" ctrlrange="{-TORQUE_LIMIT[i]} {TORQUE_LIMIT[i]}"/>'
            for i in range(7)
        )
    return f"""<mujoco model="panda_block_reach">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep}" integrator="implicitfast"/>
  <visual><global offwidth="{MAX_IMAGE_SIZE[0]}" offheight="{MAX_IMAGE_SIZE[1]}"/><quality shadowsize="{SHADOW_SIZE}"/></visual>
  <default><geom contype="0" conaffinity="0"/></default>
  {panda_meshes.asset_xml(folder) if folder else ""}
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1"/>
    <geom name="floor" type="plane" size="2 2 0.1" rgba="0.8 0.8 0.8 1"/>
    <geom name="table" type="box" pos="0.55 0 {table_height / 2}" size="0.35 0.55 {table_height / 2}" rgba="0.6 0.45 0.3 1"/>
    <body name="base" pos="0 0 0">{panda_meshes.link_geom("base") if folder else ""}{chain}</body>
    {block_xml}
    <camera name="{CAMERA_NAME}" pos="1.4 0 0.9" xyaxes="0 1 0 -0.5 0 0.87"/>
  </worldbody>
  <actuator>{actuator_xml}</actuator>
</mujoco>"""


@lru_cache(maxsize=16)
def _compiled(xml: str) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(xml)


def model(blocks: int = 2, *, timestep: float = 0.002, actuators: str = "position",
          meshes: bool | None = None, shared: bool = False) -> mujoco.MjModel:
    """A compiled MuJoCo model of :func:`mjcf` (arguments as there), compiled once per process
    (reading the meshes takes about 0.15 s).

    By default a fresh copy, which a caller may change freely. With ``shared`` the process's one
    compiled model, which nobody may change: with the meshes it holds 24 MB, so a thousand
    environments that each copied it would hold 24 GB, while each needs only its own ``MjData``
    (under 1 MB)."""
    compiled = _compiled(mjcf(blocks=blocks, timestep=timestep, actuators=actuators, meshes=meshes))
    return compiled if shared else copy.deepcopy(compiled)
