import numpy as np
import pytest

from scdp.errors import ScdpError
from scdp.robots import panda, turtlebot
from scdp.tasks import BLOCK_REACH, NAVIGATION


def test_reset_with_given_scene(task):
    env = task.make_env()
    goals = task.layouts[0]
    obs, info = env.reset(seed=1, options={"goals": goals, "target": 1})
    assert np.allclose(obs["goal"], goals[1])
    assert np.allclose(obs["goals"], goals)
    assert obs["state"].shape == (task.state_dim,)
    assert info["distance"] > task.success_radius


def test_reset_is_seeded(task):
    a, _ = task.make_env().reset(seed=7)
    b, _ = task.make_env().reset(seed=7)
    c, _ = task.make_env().reset(seed=8)
    assert np.allclose(a["goals"], b["goals"]) and not np.allclose(a["goals"], c["goals"])


def test_render_is_headless_rgb(task):
    env = task.make_env()
    env.reset(seed=0)
    env.step(env.state)
    img = env.render()
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8
    assert img.std() > 0  # something was drawn


def test_step_rejects_nan(task):
    env = task.make_env()
    env.reset(seed=0)
    with pytest.raises(ScdpError, match="action"):
        env.step(np.full(task.state_dim, np.nan))


def test_navigation_tracker_respects_datasheet_limits(rng):
    env = NAVIGATION.make_env()
    env.reset(seed=0, options={"goals": NAVIGATION.layouts[0], "target": 0})
    for _ in range(200):
        before = env.state.copy()
        env.step(before + rng.normal(0, [0.5, 0.5, 2.0]))
        v, w = env.last_twist
        assert abs(v) <= turtlebot.MAX_LINEAR_SPEED + 1e-12
        assert abs(w) <= turtlebot.MAX_ANGULAR_SPEED + 1e-12
        half = w * turtlebot.WHEEL_SEPARATION / 2
        assert max(abs(v - half), abs(v + half)) <= turtlebot.MAX_LINEAR_SPEED + 1e-9
        assert np.hypot(*(env.state[:2] - before[:2])) <= turtlebot.MAX_LINEAR_SPEED * NAVIGATION.control_dt + 1e-9


def test_navigation_reaches_a_pose_ahead():
    env = NAVIGATION.make_env(start_noise=False)
    env.reset(seed=0, options={"goals": NAVIGATION.layouts[0], "target": 0})
    for _ in range(20):
        env.step(np.array([0.3, 0.0, 0.0]))
    assert np.allclose(env.state, [0.3, 0.0, 0.0], atol=1e-3)


def test_block_reach_tracks_position_targets_within_limits():
    env = BLOCK_REACH.make_env()
    env.reset(seed=0, options={"goals": BLOCK_REACH.layouts[0], "target": 0})
    target = panda.inverse_kinematics(BLOCK_REACH.layouts[0][0])
    q0 = env.state.copy()
    env.step(target)  # far away: the step is limited by the joint velocity limits
    assert np.all(np.abs(env.state - q0) <= panda.VELOCITY_LIMIT * BLOCK_REACH.control_dt * 1.05 + 1e-3)
    for _ in range(60):
        obs, reward, terminated, truncated, info = env.step(target)
        if terminated:
            break
    assert info["success"] and terminated and reward == 1.0
    assert np.all(env.state >= panda.Q_MIN - 1e-6) and np.all(env.state <= panda.Q_MAX + 1e-6)


def test_gymnasium_env_checker(task):
    from gymnasium.utils.env_checker import check_env

    check_env(task.make_env(), skip_render_check=True)


def test_block_reach_tracks_commands_exactly_by_default():
    """The default arm reaches every (feasible) command in one period, as the deployed 1 kHz execution
    does; position servos (tracking="servo") trail it."""
    exact, servo = BLOCK_REACH.make_env(), BLOCK_REACH.make_env(tracking="servo")
    for env in (exact, servo):
        env.reset(seed=0, options={"goals": BLOCK_REACH.layouts[0], "target": 0})
    command = exact.state + 0.5 * panda.VELOCITY_LIMIT * BLOCK_REACH.control_dt  # half the reach of one step
    servo.reset(seed=0, options={"goals": BLOCK_REACH.layouts[0], "target": 0})
    exact.step(command)
    servo.step(command)
    assert np.allclose(exact.state, command, atol=1e-12)
    assert np.allclose(exact.position, panda.tcp_position(command), atol=1e-9)
    assert np.abs(servo.state - command).max() > 1e-4  # the servo's lag
    too_far = exact.state + 3.0 * panda.VELOCITY_LIMIT * BLOCK_REACH.control_dt
    exact.step(too_far)  # clipped to what the velocity limits allow in one period
    assert np.allclose(exact.state, command + panda.VELOCITY_LIMIT * BLOCK_REACH.control_dt, atol=1e-12)


def test_block_reach_refuses_an_unknown_tracking_mode():
    with pytest.raises(ValueError, match="tracking"):
        BLOCK_REACH.make_env(tracking="magic")


def test_a_fresh_environment_renders_before_any_reset():
    """docs/tasks.md's first look at a frame: make_env().render() draws the first layout at the start."""
    image = NAVIGATION.make_env().render()
    assert image.ndim == 3 and image.shape[2] == 3 and len(np.unique(image.reshape(-1, 3), axis=0)) > 10


def test_block_reach_environments_share_one_model_until_one_is_changed():
    """A thousand Block Reach scenes at once must not hold a thousand copies of the 24 MB mesh model;
    an environment whose colours are changed gets its own copy, and the others keep theirs."""
    a, b = BLOCK_REACH.make_env(), BLOCK_REACH.make_env()
    a.reset(seed=1)
    b.reset(seed=2)
    assert a.model is b.model
    before = a.position
    painted = a.own_model()
    painted.geom("block0").rgba = (1.0, 0.0, 1.0, 1.0)
    assert painted is a.model and a.model is not b.model
    assert np.allclose(a.position, before)  # the copy keeps the state
    assert not np.allclose(b.model.geom("block0").rgba, (1.0, 0.0, 1.0, 1.0))
    a.step(a.state)  # and steps on its own data
    assert np.allclose(a.position, before, atol=1e-9)
