"""Camera calibration, the simulated RGB-D camera, the colour detector and goal location."""

import json

import numpy as np
import pytest

from scdp.errors import ScdpError
from scdp.perception import Camera, ColorDetector, DepthNoise, Detection, block_reach_camera, gl, locate, paint_blocks, render_rgbd
from scdp.tasks import BLOCK_REACH


@pytest.fixture(scope="module")
def scene():
    """A Block Reach scene with the target painted, rendered by the cell's camera."""
    env = BLOCK_REACH.make_env()
    env.reset(options={"goals": [[0.45, 0.15], [0.6, -0.15]], "target": 1})
    paint_blocks(env.own_model(), env.target, 2)
    camera = block_reach_camera()
    rgb, depth = render_rgbd(env, camera)
    return env, camera, rgb, depth


def test_projection_and_backprojection_round_trip():
    camera = Camera.look_at((1.1, 0.3, 0.8), (0.5, -0.1, 0.1), width=800, height=600, fx=700.0, fy=650.0, cx=390.0, cy=310.0)
    points = np.random.default_rng(0).uniform([0.3, -0.4, 0.0], [0.8, 0.4, 0.4], size=(50, 3))
    pixels, depth = camera.project(points)
    assert np.all(depth > 0)
    assert np.allclose(camera.backproject(pixels, depth), points, atol=1e-9)
    # the optical axis passes through the principal point
    axis_point = camera.base_from_camera[:3, 3] + camera.base_from_camera[:3, 2]
    assert np.allclose(camera.project([axis_point])[0], [[390.0, 310.0]], atol=1e-9)


def test_calibration_file_round_trip_and_conventions(tmp_path):
    camera = block_reach_camera()
    path = camera.save(tmp_path / "camera.json")
    data = json.loads(path.read_text())
    assert data["k"][2] == camera.cx and data["k"][5] == camera.cy and data["k"][8] == 1.0
    again = Camera.load(path)
    assert again.to_dict() == camera.to_dict()


@pytest.mark.parametrize("change, field", [
    ({"base_from_camera": [[1, 0, 0, 0], [0, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}, "base_from_camera"),
    ({"base_from_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]]}, "base_from_camera"),
    ({"k": [600, 0, 320, 0, 600, 240, 0, 0]}, "k"),
    ({"k": [-600, 0, 320, 0, 600, 240, 0, 0, 1]}, "fx"),
    ({"width": "640"}, "width"),
    ({"d": [0.1, 0.0, 0.0]}, "d"),
])
def test_bad_calibrations_are_refused_naming_the_field(change, field):
    data = {**block_reach_camera().to_dict(), **change}
    with pytest.raises(ScdpError) as err:
        Camera.from_dict(data)
    assert err.value.field == field


def test_rendered_depth_is_metric_along_the_optical_axis(scene):
    env, camera, rgb, depth = scene
    assert rgb.dtype == np.uint8 and rgb.shape == (camera.height, camera.width, 3)
    assert depth.dtype == np.float32 and depth.shape == (camera.height, camera.width)
    # the pixel where the target block's top centre projects sees it at its optical-frame depth
    top = env.goals[env.target] + [0, 0, 0.025]
    (u, v), z = camera.project([top])[0][0], camera.project([top])[1][0]
    assert abs(depth[int(round(v)), int(round(u))] - z) < 2e-3


def test_located_goals_match_the_blocks(scene):
    env, camera, rgb, depth = scene
    located = locate(ColorDetector().detect(rgb), depth, camera)
    assert np.linalg.norm(located - env.goals[[1, 0]], axis=1).max() < 0.005


def test_depth_noise_grows_with_distance_and_leaves_holes(scene):
    _, _, _, depth = scene
    noisy = DepthNoise().apply(depth, np.random.default_rng(0))
    valid = (depth > 0) & (noisy > 0)
    assert 0 < (depth > 0).sum() - valid.sum()  # holes
    error = np.abs(noisy - depth)[valid]
    near, far = depth[valid] < np.percentile(depth[valid], 20), depth[valid] > np.percentile(depth[valid], 80)
    assert error[far].std() > error[near].std()


def test_detector_failure_paths_never_make_up_a_goal(scene):
    env, camera, rgb, depth = scene
    detections = ColorDetector().detect(rgb)
    target = next(d for d in detections if d.label == "target")
    with pytest.raises(ScdpError, match="no distractor block found"):
        locate([target], depth, camera)
    with pytest.raises(ScdpError, match="2 detections labelled 'target'"):
        locate(detections + [target], depth, camera)
    with pytest.raises(ScdpError, match="no valid depth"):
        locate(detections, np.zeros_like(depth), camera)
    far = Detection("distractor", (0, 0, 40, 40), 1.0)  # the background: floor far behind the table
    with pytest.raises(ScdpError, match="outside the workspace"):
        locate([target, far], depth, camera)
    blank = np.zeros_like(rgb)
    assert ColorDetector().detect(blank) == []
    with pytest.raises(ScdpError) as err:
        ColorDetector().detect(rgb.astype(np.float32))
    assert err.value.field == "rgb"


@pytest.mark.parametrize("env, want", [({}, ["egl", "osmesa"]), ({"DISPLAY": ":0"}, ["default"]),
                                       ({"DISPLAY": ":0", "MUJOCO_GL": " OSMesa"}, ["osmesa"])])
def test_the_gl_backends_tried_follow_the_environment(env, want, monkeypatch):
    for name in ("DISPLAY", "MUJOCO_GL"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    assert gl.candidates() == want


def test_an_explicit_gl_choice_that_fails_names_its_packages(monkeypatch):
    monkeypatch.setattr(gl, "_CHOSEN", {})
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setattr(gl, "library_loads", lambda name: False)
    with pytest.raises(ScdpError, match=r"render: .*OSMesa: libOSMesa not found.*libosmesa6, or unset MUJOCO_GL"):
        gl.new_renderer(None, 8, 8)
