"""1 kHz jerk-limited interpolation, streaming across chunks, the limit check and execution in MuJoCo."""

import numpy as np
import pytest

from scdp.errors import ScdpError
from scdp.execution import PANDA_LIMITS, JerkLimitedStreamer, SimulatedPanda, interpolate, limit_ratios, tracking_error, violations
from scdp.robots import panda


def wavy_waypoints(n=40, seed=0):
    """A curvy joint path near the ready pose, one waypoint per 0.1 s (some steps are fast)."""
    t = np.linspace(0, 1, n)[:, None]
    phase = np.random.default_rng(seed).uniform(0, np.pi, 7)
    return panda.READY_POSE + 0.4 * np.sin(2 * np.pi * t + phase) * np.array([1, 0.5, 1, 0.5, 1, 0.5, 1])


def test_interpolate_respects_every_limit_and_hits_the_ends():
    w = wavy_waypoints()
    q = interpolate(w, step=0.1, rate=1000)
    assert q.shape[1] == 7 and len(q) >= (len(w) - 1) * 100 + 1
    assert np.allclose(q[0], w[0]) and np.allclose(q[-1], w[-1], atol=1e-9)
    ratios = limit_ratios(q, 1000)
    assert violations(ratios) == [] and max(ratios[k] for k in ("velocity", "acceleration", "jerk")) <= 1.0


def test_the_limit_check_catches_a_violating_trajectory():
    w = wavy_waypoints()
    naive = np.vstack([np.linspace(a, b, 100, endpoint=False) for a, b in zip(w[:-1], w[1:])] + [w[-1:]])  # linear, 1 kHz
    ratios = limit_ratios(naive, 1000)
    assert "jerk" in violations(ratios) and "acceleration" in violations(ratios)
    jump = np.vstack([np.repeat(w[:1], 10, axis=0), np.repeat(w[:1] + 0.01, 10, axis=0)])  # a 10 mrad step
    assert violations(limit_ratios(jump, 1000))[:1] == ["velocity"]


def test_streaming_chunks_join_without_a_discontinuity():
    w = wavy_waypoints(48, seed=1)
    streamer = JerkLimitedStreamer(w[0])
    parts = [streamer.push(w[1:9])]
    position, velocity, acceleration = streamer.state
    assert np.linalg.norm(velocity) > 0  # the first chunk ends in motion: the next one must carry it on
    parts.append(streamer.push(w[9:30]))
    # the next chunk replans from a slightly different place, as a policy re-planning would
    parts.append(streamer.push(w[30:] + 0.002, final=True))
    q = np.vstack([w[:1]] + [p.position for p in parts])
    ratios = limit_ratios(q, 1000)
    assert violations(ratios) == []
    for before, after in zip(parts[:-1], parts[1:]):
        # the samples around each join differ by no more than the velocity limit allows per tick
        assert np.all(np.abs(after.position[0] - before.position[-1]) <= PANDA_LIMITS.velocity / 1000 + 1e-12)
        assert np.all(np.abs(after.acceleration[0] - before.acceleration[-1]) <= PANDA_LIMITS.jerk / 1000 + 1e-9)
    assert np.allclose(parts[-1].velocity[-1], 0) and np.allclose(q[-1], w[-1] + 0.002)


def test_waypoints_reached_on_their_samples_and_slower_when_limits_bind():
    w = np.vstack([panda.READY_POSE, panda.READY_POSE + 0.3])  # 0.3 rad in 0.1 s: far over the acceleration limits
    samples = JerkLimitedStreamer(w[0]).push(w[1:], final=True)
    assert np.allclose(samples.position[samples.waypoint_index[-1]], w[1])
    assert len(samples) > 100  # took longer than the 10 Hz schedule


def test_bad_waypoints_are_refused():
    with pytest.raises(ScdpError, match="outside its limits"):
        interpolate(np.vstack([panda.READY_POSE, panda.READY_POSE + [0, 0, 0, 3.0, 0, 0, 0]]))
    with pytest.raises(ScdpError) as err:
        interpolate(np.zeros((5, 6)))
    assert err.value.field == "waypoints"
    with pytest.raises(ScdpError) as err:
        interpolate(np.full((3, 7), np.nan))
    assert err.value.field == "waypoints"


def test_the_simulated_arm_tracks_the_1khz_path():
    w = wavy_waypoints(20)
    samples = JerkLimitedStreamer(w[0]).push(w[1:], final=True)
    arm = SimulatedPanda([[0.5, 0.1, 0.1], [0.5, -0.1, 0.1]], w[0])
    measured = arm.follow(samples)
    err = tracking_error(samples.position, measured)
    assert err["joint_rad"] < 5e-3 and err["tcp_m"] < 2e-3
    assert np.allclose(arm.joint_positions(), measured[-1])


# A segment from the deploy test (untrained tiny planner, Block Reach, scene seed 4): joint 7 moving
# at +2.35 rad/s towards a waypoint 0.11 rad below its limit, to be passed at -2.35 rad/s.
OVERRUN_CASE = {
    "position": [-0.15688377618789678, -0.4398422837257387, 0.20018416643142697, -2.354536533355713, 0.09065840393304814,
                 2.1765618324279785, 2.015680074691772],
    "velocity": [0.008332133293151765, -1.9574999999999998, 0.73621105402708, -0.02001643180847103, 0.5820773169398322,
                 1.4294213056564338, 2.3489999999999993],
    "acceleration": [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    "target": [-0.15689483284950256, -1.0661633014678955, 0.18739460408687592, -2.7281603813171387, 0.07036405801773071,
               2.084170341491699, 2.787745475769043],
    "target_velocity": [0.23580502718687057, -0.08526533842086792, -0.6670503690838814, -1.7441952228546143, -0.10826148092746735,
                        0.0, -2.3489999999999998],
    "previous": [-0.15688377618789673, -0.4398422837257385, 0.200184166431427, -2.354536533355713, 0.09065840393304825,
                 2.1765618324279785, 2.0156800746917725],
}


def test_a_segment_whose_turn_around_would_cross_a_limit_stays_inside():
    """Ruckig's ``position_extrema`` reported this segment inside the range while its samples went 0.046
    rad past joint 7's limit (the deploy test's ``limit_violations == ['position']``). The streamer now
    checks the samples a robot will get, and brakes or stops on the waypoint instead."""
    c = OVERRUN_CASE
    streamer = JerkLimitedStreamer(np.array(c["position"]), step=0.1)
    streamer._inp.current_velocity = c["velocity"]
    streamer._previous = np.array(c["previous"])
    pos, vel, acc = [], [], []
    streamer._segment(np.array(c["target"]), np.array(c["target_velocity"]), pos, vel, acc, 0)
    q = np.array(pos)
    assert np.all(q >= panda.Q_MIN - 1e-7) and np.all(q <= panda.Q_MAX + 1e-7), (q.max(0) - panda.Q_MAX).max()
    assert np.allclose(q[-1], c["target"], atol=1e-6)  # and the waypoint is still reached
