from dataclasses import replace

import numpy as np
import pytest

from scdp.data.bezier import bezier, sample_by_arc_length, signed_bend, turning_path
from scdp.data.generate import ARRIVED, generate_demos
from scdp.errors import ScdpError
from scdp.metrics import resample
from scdp.tasks import BLOCK_REACH, NAVIGATION


def test_arc_length_sampling_spacing():
    path = sample_by_arc_length(np.zeros(2), np.array([1.0, 1.0]), np.array([2.0, 0.0]), 0.02)
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    assert np.allclose(steps[:-1], 0.02, rtol=0.02)
    assert steps[-1] <= 0.02 + 1e-9
    assert np.allclose(path[-1], [2, 0]) and np.allclose(path[0], [0, 0])


def test_bezier_midpoint_by_hand():
    # B(1/2) = p0/4 + p1/2 + p2/4
    assert np.allclose(bezier(np.zeros(2), np.array([1.0, 2.0]), np.array([2.0, 0.0]), [0.5])[0], [1.0, 1.0])


def test_signed_bend_sides():
    left = sample_by_arc_length(np.zeros(2), np.array([1.0, 1.0]), np.array([2.0, 0.0]), 0.01)
    right = left * [1, -1]
    assert signed_bend(left) == pytest.approx(0.25, abs=0.01)  # control offset 1 chord/2 -> bend 1/4
    assert signed_bend(right) == pytest.approx(-0.25, abs=0.01)
    assert signed_bend(np.linspace([0, 0], [1, 0], 10)) == 0.0


@pytest.mark.parametrize("task", [NAVIGATION, BLOCK_REACH], ids=lambda t: t.name)
def test_control_points_span_straight_to_curved_on_both_sides(task):
    rng = np.random.default_rng(0)
    start, goal = task.start_point, task.layouts[4][0]
    bends = np.array([
        signed_bend(sample_by_arc_length(start, task.sample_control_point(rng, start, goal), goal, task.step_size))
        for _ in range(300)
    ])
    assert np.abs(bends).min() < 0.05  # near straight
    assert np.abs(bends).max() > 0.2  # strongly curved
    assert 0.3 < np.mean(bends > 0) < 0.7  # both sides


def test_demos_succeed_and_record_next_state_actions(small_datasets, task):
    ds = small_datasets[task.name]
    assert ds.num_episodes == 12
    for i in range(ds.num_episodes):
        ep = ds.episode(i)
        goal = ep["goals"][ep["target"]]
        path = task.episode_path(ep)
        # a demo runs to the goal itself, through the success radius, not to the radius's edge
        assert np.linalg.norm(path[-1] - goal) < ARRIVED * task.success_radius
        assert (np.linalg.norm(path - goal, axis=1) < task.success_radius).sum() >= 2
        # the recorded next state follows the commanded action closely
        gap = np.linalg.norm(task.task_space(ep["state"][1:]) - task.task_space(ep["action"][:-1]), axis=1)
        assert gap.max() < task.step_size
        steps = np.linalg.norm(np.diff(task.task_space(ep["state"]), axis=0), axis=1)
        assert np.median(steps) == pytest.approx(task.step_size, rel=0.25)


def test_block_reach_paths_leave_the_table_plane(small_datasets):
    ds = small_datasets["block_reach"]
    peaks = [BLOCK_REACH.task_space(ds.episode(i)["state"])[:, 2].max() for i in range(ds.num_episodes)]
    assert max(peaks) > BLOCK_REACH.start_point[2] + 0.02


def test_generation_is_seeded():
    a, _ = generate_demos(NAVIGATION, 3, seed=5, progress=False)
    b, _ = generate_demos(NAVIGATION, 3, seed=5, progress=False)
    c, _ = generate_demos(NAVIGATION, 3, seed=6, progress=False)
    assert np.array_equal(a.state, b.state)
    assert a.state.shape != c.state.shape or not np.array_equal(a.state, c.state)


def test_fixed_scene_preset_uses_the_six_configurations():
    ds, _ = generate_demos(NAVIGATION, 6, seed=0, scenes="fixed", progress=False)
    for i in range(6):
        assert np.allclose(ds.episode(i)["goals"], NAVIGATION.layouts[i])


def test_single_configuration_mode_keeps_the_goals_and_draws_both_targets():
    ds, _ = generate_demos(NAVIGATION, 12, seed=0, scenes="layout_3", progress=False)
    targets = set()
    for i in range(ds.num_episodes):
        ep = ds.episode(i)
        assert np.allclose(ep["goals"], NAVIGATION.layouts[2])
        targets.add(ep["target"])
    assert targets == {0, 1}  # the target is still drawn at random
    assert ds.attrs["generator"]["scenes"] == "layout_3"


@pytest.mark.parametrize("kwargs, field", [
    ({"num_demos": -1}, "num_demos"),
    ({"num_demos": 0}, "num_demos"),
    ({"seed": "x"}, "seed"),
    ({"scenes": "weird"}, "scenes"),
    ({"scenes": "layout_7"}, "scenes"),
])
def test_generator_rejects_bad_arguments(kwargs, field):
    args = {"task": "navigation", "num_demos": 2, "seed": 0, **kwargs}
    with pytest.raises(ScdpError) as err:
        generate_demos(args.pop("task"), args.pop("num_demos"), args.pop("seed"), progress=False, **args)
    assert err.value.field == field


def test_generation_that_accepts_almost_nothing_stops_in_one_line_with_what_to_change():
    """max_episode_steps shorter than every demo: it used to sit at 0/20 for ever; it stops after
    JUDGE_AFTER attempts, naming why they failed, the steps the paths take, and the limit."""
    short = replace(NAVIGATION, max_episode_steps=20)
    with pytest.raises(ScdpError) as err:
        generate_demos(short, 20, seed=0, progress=False)
    assert err.value.field == "demos"
    message = err.value.message
    assert message.startswith("0 of 20 demos after 200 attempts") and "200 too long" in message
    assert "max_episode_steps is 20: raise it to at least" in message and "\n" not in message


def test_a_dataset_made_with_many_redraws_says_what_it_lost():
    """max_episode_steps = 150 on Navigation: about half the attempts are too long; the demos are made,
    with a warning naming the redraws and the bias; the default limit makes them without one."""
    _, report = generate_demos(replace(NAVIGATION, max_episode_steps=150), 20, seed=0, progress=False)
    assert report["demos"] == 20 and report["failures"] > 0.2 * report["attempts"]
    (warning,) = report["warnings"]
    assert "too long" in warning and "max_episode_steps is 150" in warning and "under-represents" in warning
    _, plain = generate_demos(NAVIGATION, 20, seed=0, progress=False)
    assert plain["warnings"] == []


@pytest.mark.parametrize("from_point", [False, True], ids=["from_start", "from_point"])
@pytest.mark.parametrize("task", [NAVIGATION, BLOCK_REACH], ids=lambda t: t.name)
def test_a_turning_path_follows_one_demo_curve_then_turns_smoothly_onto_another(task, from_point):
    """turning_path is its first curve's demo path up to the turn, ends on the goal, takes another course
    after the turn (a second curve from the start, or from the turn), and turns without a kink: on Navigation
    no two steps of 40 paths differ in heading by 50 degrees (a switch from one curve to the other in one step
    turns by up to 90)."""
    start, goal = task.start_point, task.layouts[4][0]
    turns, bent = [], 0
    for seed in range(40):
        path, control = turning_path(task, np.random.default_rng(seed), start, goal, from_point=from_point)
        first = sample_by_arc_length(start, control, goal, task.step_size)
        same = int(np.argmax(np.linalg.norm(path[:len(first)] - first[:len(path)], axis=1) > 1e-9))
        assert same >= 1 and np.allclose(path[:same], first[:same])
        assert np.allclose(path[0], start) and np.allclose(path[-1], goal)
        steps = np.diff(path, axis=0)[:-1]
        heading = steps / np.linalg.norm(steps, axis=1, keepdims=True)
        turns.append(np.degrees(np.arccos(np.clip((heading[1:] * heading[:-1]).sum(1), -1, 1))).max())
        apart = np.linalg.norm(resample(path, 100) - resample(first, 100), axis=1).max()  # same times along each
        bent += apart > 0.05 * np.linalg.norm(goal - start)
    assert bent >= 20
    if task is NAVIGATION:
        assert max(turns) < 50


def test_turning_demos_change_course_and_none_draws_nothing():
    """turning=0 draws exactly what the generator drew before the option existed (the committed demos
    regenerate bit for bit); turning=1 makes every demo change course, from the same scenes."""
    plain, _ = generate_demos("navigation", 6, 4, progress=False)
    zero, _ = generate_demos("navigation", 6, 4, progress=False, turning=0.0)
    turned, _ = generate_demos("navigation", 6, 4, progress=False, turning=1.0)
    assert zero.fingerprint() == plain.fingerprint() and turned.fingerprint() != plain.fingerprint()
    assert np.array_equal(turned.attrs["control_points"].shape, plain.attrs["control_points"].shape)
    assert turned.attrs["generator"]["turning"] == 1.0
    with pytest.raises(ScdpError) as err:
        generate_demos("navigation", 2, 0, progress=False, turning=1.5)
    assert err.value.field == "turning"
    with pytest.raises(ScdpError) as err:
        generate_demos("navigation", 2, 0, progress=False, turning=0.5, turn_from="end")
    assert err.value.field == "turn_from"
    from_point, _ = generate_demos("navigation", 6, 4, progress=False, turning=1.0, turn_from="point")
    assert from_point.fingerprint() not in (turned.fingerprint(), plain.fingerprint())


def test_a_turn_sharper_than_the_robot_can_follow_is_redrawn_and_named():
    """Navigation's turning demos (seed 0) draw paths (two) that turn faster than the TurtleBot's datasheet rate:
    both are redrawn, each reported as too sharp, so that the dataset holds only motions the robot can make
    (the dataset refuses any other: DemoDataset checks every action's reach)."""
    dataset, report = generate_demos("navigation", 1000, 0, progress=False, turning=0.5)
    assert report["failures"] >= 1 and all("turns too sharply" in f["reason"] for f in report["failure_reasons"])
    assert NAVIGATION.reach_used(dataset.state, dataset.action).max() <= 1.0


def test_the_parameter_at_a_length_inverts_the_arc_length():
    """On a straight Bézier with its control point a quarter of the way, the point moves fast, then slow: the
    parameter at half the length is not 0.5, and the curve there is half way."""
    from scdp.data.bezier import parameter_at_length

    start, control, end = np.zeros(2), np.array([0.5, 0.0]), np.array([2.0, 0.0])
    t = parameter_at_length(lambda u: bezier(start, control, end, u), 1.0)
    assert abs(t - 0.5) > 0.05 and np.allclose(bezier(start, control, end, [t])[0], [1.0, 0.0], atol=1e-3)
