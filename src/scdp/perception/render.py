"""Headless RGB-D frames of a MuJoCo scene from a calibrated :class:`~scdp.perception.camera.Camera`.

:func:`render_rgbd` places the model's ``rgbd`` camera (see :func:`scdp.robots.panda.mjcf`)
at the calibration's extrinsic with its intrinsics, renders colour and depth offscreen, and turns
MuJoCo's depth buffer into metric depth along the optical axis (what a RealSense reports).
:class:`DepthNoise` then makes that depth look like a RealSense's: noise growing with the square
of the distance, 1 mm quantisation, and holes (random dropouts and missing depth at edges).

Off-screen rendering needs an OpenGL context. It is chosen at the first render, not at import
(:mod:`scdp.perception.gl`): the user's ``MUJOCO_GL`` if set; else with a ``DISPLAY`` MuJoCo's
default; else EGL, then OSMesa. Where none works, rendering raises one ``ScdpError`` (``render``)
naming the Debian packages to install; nothing else in scdp needs OpenGL.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from scdp.errors import ScdpError
from scdp.perception import gl
from scdp.perception.camera import Camera
from scdp.robots import panda

TARGET_RGBA = (0.15, 0.75, 0.2, 1.0)  # green
DISTRACTOR_RGBA = (0.15, 0.3, 0.85, 1.0)  # blue
NO_DEPTH = 0.0  # a RealSense marks a pixel without depth with 0
MAX_RANGE = 6.0  # metres; farther is background, reported as NO_DEPTH
CV_TO_GL = np.diag([1.0, -1.0, -1.0])  # optical frame (y down, z forward) -> MuJoCo camera (y up, z back)


@dataclass(frozen=True)
class DepthNoise:
    """RealSense-like depth errors (defaults near a D435 at 640x480).

    sigma = ``sigma_at_1m`` * z^2 (stereo depth error grows with the square of the distance);
    values are quantised to ``quantum`` metres; ``dropout`` of the pixels lose their depth at
    random; and a pixel next to a depth step larger than ``edge_jump`` metres loses it with
    probability ``edge_dropout`` (stereo matching fails at occlusion edges).
    """

    sigma_at_1m: float = 0.0025
    quantum: float = 0.001
    dropout: float = 0.01
    edge_jump: float = 0.03
    edge_dropout: float = 0.5

    def apply(self, depth: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """A noisy copy of metric ``depth`` (H, W); pixels without depth stay ``NO_DEPTH``."""
        valid = depth > NO_DEPTH
        noisy = depth + rng.standard_normal(depth.shape) * self.sigma_at_1m * depth**2
        noisy = np.round(noisy / self.quantum) * self.quantum
        jump = np.zeros_like(valid)
        dz_v, dz_u = np.abs(np.diff(depth, axis=0)) > self.edge_jump, np.abs(np.diff(depth, axis=1)) > self.edge_jump
        jump[1:] |= dz_v
        jump[:-1] |= dz_v
        jump[:, 1:] |= dz_u
        jump[:, :-1] |= dz_u
        holes = (rng.random(depth.shape) < self.dropout) | (jump & (rng.random(depth.shape) < self.edge_dropout))
        return np.where(valid & ~holes, noisy, NO_DEPTH).astype(np.float32)


def paint_blocks(model: mujoco.MjModel, target: int, n_blocks: int) -> None:
    """Colour block ``target`` as the target and the other blocks as distractors."""
    for k in range(n_blocks):
        model.geom(f"block{k}").rgba = TARGET_RGBA if k == target else DISTRACTOR_RGBA


def place_camera(model: mujoco.MjModel, camera: Camera) -> int:
    """Set the model's ``rgbd`` camera to ``camera``'s pose and intrinsics; returns its id."""
    try:
        cid = model.camera(panda.CAMERA_NAME).id
    except KeyError:
        raise ScdpError("model", f"has no camera named {panda.CAMERA_NAME!r} (build it with scdp.robots.panda.mjcf)") from None
    if camera.width > model.vis.global_.offwidth or camera.height > model.vis.global_.offheight:
        raise ScdpError("camera", f"{camera.width}x{camera.height} is larger than the offscreen buffer "
                                  f"{model.vis.global_.offwidth}x{model.vis.global_.offheight}")
    if np.any(camera.distortion != 0):
        raise ScdpError("d", "the simulated camera renders without lens distortion; use d = 0")
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, (camera.base_from_camera[:3, :3] @ CV_TO_GL).ravel())
    model.cam_pos[cid] = camera.base_from_camera[:3, 3]
    model.cam_quat[cid] = quat
    model.cam_mode[cid] = mujoco.mjtCamLight.mjCAMLIGHT_FIXED
    # Intrinsics in pixel units: a sensor of width x height "pixels" with focal lengths fx, fy
    # and the principal point's offset from the sensor centre (as MuJoCo measures it: both axes flipped).
    model.cam_resolution[cid] = (camera.width, camera.height)
    model.cam_sensorsize[cid] = (camera.width, camera.height)
    model.cam_intrinsic[cid] = (camera.fx, camera.fy, (camera.width - 1) / 2 - camera.cx, (camera.height - 1) / 2 - camera.cy)
    return cid


_RENDERERS: dict = {}


def _renderer(model: mujoco.MjModel, camera: Camera) -> mujoco.Renderer:
    key = (id(model), camera.width, camera.height)
    if key not in _RENDERERS:
        if len(_RENDERERS) > 8:
            for r in _RENDERERS.values():
                r.close()
            _RENDERERS.clear()
        _RENDERERS[key] = gl.new_renderer(model, camera.height, camera.width)
    return _RENDERERS[key]


def render_rgb(scene, camera: Camera) -> np.ndarray:
    """Colour (H, W, 3) uint8 of ``scene`` seen by ``camera``, its kinematics forwarded first: a video
    frame, which needs no depth (rendering it too doubles a frame's cost). Placing the camera changes
    the model, so an environment that shares its compiled model is given its own first."""
    if hasattr(scene, "own_model"):
        scene.own_model()
    model, data = scene.model, scene.data
    cid = place_camera(model, camera)
    mujoco.mj_forward(model, data)
    renderer = _renderer(model, camera)
    renderer.disable_depth_rendering()
    renderer.update_scene(data, camera=cid)
    return renderer.render().copy()


def render_rgbd(scene, camera: Camera, *, noise: DepthNoise | None = None,
                rng: np.random.Generator | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Colour (H, W, 3) uint8 and metric depth (H, W) float32 of ``scene`` seen by ``camera``.

    ``scene`` is anything holding a MuJoCo ``model`` and ``data`` built by
    :func:`scdp.robots.panda.mjcf` (a Block Reach environment, or the 1 kHz simulated arm).
    Depth is the z coordinate in the optical frame, in metres; ``NO_DEPTH`` (0) where nothing is
    within ``MAX_RANGE``. With ``noise`` (and its seeded ``rng``), depth gets RealSense-like errors.
    """
    rgb = render_rgb(scene, camera)
    model, data = scene.model, scene.data
    cid = place_camera(model, camera)
    renderer = _renderer(model, camera)
    renderer.enable_depth_rendering()
    renderer.update_scene(data, camera=cid)
    depth = renderer.render().astype(np.float32)
    renderer.disable_depth_rendering()
    depth[~np.isfinite(depth) | (depth > MAX_RANGE)] = NO_DEPTH
    if noise is not None:
        if rng is None:
            raise ScdpError("rng", "depth noise needs a seeded numpy Generator")
        depth = noise.apply(depth, rng)
    return rgb, depth
