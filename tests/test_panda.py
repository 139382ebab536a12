import mujoco
import numpy as np
import pytest

from scdp.errors import ScdpError
from scdp.robots import panda


def test_zero_pose_flange_by_hand():
    # All joints at zero: the arm stands upright; a4 and a5 cancel, a7 = 0.088 sticks out in x,
    # and the flange points down: z = 0.333 + 0.316 + 0.384 - 0.107.
    F = panda.flange_pose(np.zeros(7))
    assert np.allclose(F[:3, 3], [0.088, 0.0, 0.926], atol=1e-9)
    assert np.allclose(F[:3, :3], np.diag([1.0, -1.0, -1.0]), atol=1e-9)


def test_first_joint_rotates_about_vertical():
    q = np.zeros(7)
    q[0] = np.pi / 2
    assert np.allclose(panda.flange_pose(q)[:3, 3], [0.0, 0.088, 0.926], atol=1e-9)


def test_ready_pose_tcp_matches_datasheet():
    assert np.allclose(panda.tcp_position(panda.READY_POSE), [0.307, 0.0, 0.487], atol=1e-3)


def test_fk_matches_mujoco_model(rng):
    model = mujoco.MjModel.from_xml_string(panda.mjcf())
    data = mujoco.MjData(model)
    for _ in range(20):
        q = rng.uniform(panda.Q_MIN, panda.Q_MAX)
        data.qpos[:7] = q
        mujoco.mj_forward(model, data)
        assert np.allclose(data.site("tcp").xpos, panda.tcp_position(q), atol=1e-9)
        assert np.allclose(data.body("flange").xpos, panda.flange_pose(q)[:3, 3], atol=1e-9)


def test_fk_broadcasts_over_batches(rng):
    Q = rng.uniform(panda.Q_MIN, panda.Q_MAX, size=(4, 3, 7))
    batched = panda.tcp_position(Q)
    assert batched.shape == (4, 3, 3)
    assert np.allclose(batched[2, 1], panda.tcp_position(Q[2, 1]))


def test_jacobian_matches_finite_differences(rng):
    q = rng.uniform(panda.Q_MIN, panda.Q_MAX)
    J = panda.tcp_jacobian(q)
    h = 1e-6
    fd = np.column_stack([(panda.tcp_position(q + h * e) - panda.tcp_position(q - h * e)) / (2 * h) for e in np.eye(7)])
    assert np.allclose(J, fd, atol=1e-6)


def test_ik_round_trip(rng):
    for _ in range(10):
        q_true = np.clip(panda.READY_POSE + rng.normal(0, 0.3, 7), panda.Q_MIN, panda.Q_MAX)
        target = panda.tcp_position(q_true)
        q = panda.inverse_kinematics(target)
        assert np.linalg.norm(panda.tcp_position(q) - target) < 1e-3
        assert np.all(q >= panda.Q_MIN) and np.all(q <= panda.Q_MAX)


def test_ik_refuses_unreachable_target():
    with pytest.raises(ScdpError, match="beyond the Panda's reach") as err:
        panda.inverse_kinematics([1.2, 0.0, 0.1], field="goal")
    assert err.value.field == "goal"
