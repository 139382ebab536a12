"""A calibrated RGB-D camera: pinhole intrinsics, lens distortion and its pose in the robot base frame.

Conventions (those of ROS ``sensor_msgs/CameraInfo`` and OpenCV):

* **Image.** Pixel ``(u, v)``: ``u`` to the right, ``v`` down, the centre of the top-left pixel
  at (0, 0). ``K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` in pixels; ``d`` is OpenCV's
  distortion vector (``plumb_bob``: k1, k2, p1, p2, k3), all zeros for the simulated camera.
* **Camera frame.** The optical frame: x right, y down, z forward along the optical axis (the
  ``*_optical_frame`` of a RealSense ROS driver). Depth is the z coordinate, in metres.
* **Extrinsic.** ``base_from_camera`` (4x4) maps a point in the optical frame to the robot
  base frame (``panda_link0``): ``p_base = T @ [p_cam, 1]``. It must be rigid.

The calibration file is JSON::

    {"width": 640, "height": 480, "distortion_model": "plumb_bob",
     "k": [fx, 0, cx, 0, fy, cy, 0, 0, 1], "d": [0, 0, 0, 0, 0],
     "base_from_camera": [[r11, r12, r13, tx], [r21, r22, r23, ty], [r31, r32, r33, tz], [0, 0, 0, 1]]}

``k`` and ``d`` are CameraInfo's fields as published (row-major ``K``); ``base_from_camera`` is
what a hand-eye calibration (for example OpenCV's ``calibrateHandEye``) gives for a fixed camera.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from scdp.errors import ScdpError, finite_array
from scdp.io import write_json
from scdp.tasks import BLOCK_REACH, Task

DISTORTION_LENGTHS = (0, 4, 5, 8, 12, 14)  # what OpenCV accepts
RIGID_TOL = 1e-6


def rigid_transform(value, field_name: str) -> np.ndarray:
    """``value`` as a (4, 4) rigid transform: orthonormal rotation with det +1, last row 0 0 0 1."""
    T = finite_array(value, field_name)
    if T.shape != (4, 4):
        raise ScdpError(field_name, f"expected a 4x4 matrix, got shape {T.shape}")
    if not np.allclose(T[3], [0, 0, 0, 1], atol=RIGID_TOL):
        raise ScdpError(field_name, f"last row must be [0, 0, 0, 1], got {T[3].tolist()}")
    R = T[:3, :3]
    err = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if err > RIGID_TOL or np.linalg.det(R) < 0:
        raise ScdpError(field_name, f"not a rigid transform: the rotation is not orthonormal with det +1 "
                                    f"(|R^T R - I| = {err:.2g}, det = {np.linalg.det(R):.4f})")
    return T


@dataclass(frozen=True)
class Camera:
    """Intrinsics (pixels), image size and the base-from-camera extrinsic of one RGB-D camera."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    base_from_camera: np.ndarray
    distortion: np.ndarray = field(default_factory=lambda: np.zeros(5))

    def __post_init__(self):
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= 16384:
                raise ScdpError(name, f"must be a whole number of pixels from 1 to 16384, got {value!r}")
        for name in ("fx", "fy"):
            value = getattr(self, name)
            if not isinstance(value, (int, float, np.number)) or not np.isfinite(value) or value <= 0:
                raise ScdpError(name, f"must be a positive focal length in pixels, got {value!r}")
        for name, size in (("cx", self.width), ("cy", self.height)):
            value = getattr(self, name)
            if not isinstance(value, (int, float, np.number)) or not np.isfinite(value) or not 0 <= value <= size:
                raise ScdpError(name, f"the principal point must lie in the image (0..{size}), got {value!r}")
        object.__setattr__(self, "base_from_camera", rigid_transform(self.base_from_camera, "base_from_camera"))
        d = finite_array(self.distortion, "d").ravel()
        if len(d) not in DISTORTION_LENGTHS:
            raise ScdpError("d", f"OpenCV distortion has {', '.join(map(str, DISTORTION_LENGTHS))} coefficients, got {len(d)}")
        object.__setattr__(self, "distortion", d)

    # -- frames -------------------------------------------------------------------------------
    @property
    def K(self) -> np.ndarray:
        """(3, 3) intrinsic matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def camera_from_base(self) -> np.ndarray:
        R, t = self.base_from_camera[:3, :3], self.base_from_camera[:3, 3]
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R.T, -R.T @ t
        return T

    def to_camera(self, points_base) -> np.ndarray:
        """(N, 3) base-frame points -> (N, 3) optical-frame points."""
        p = np.atleast_2d(np.asarray(points_base, dtype=np.float64))
        T = self.camera_from_base
        return p @ T[:3, :3].T + T[:3, 3]

    def to_base(self, points_camera) -> np.ndarray:
        """(N, 3) optical-frame points -> (N, 3) base-frame points."""
        p = np.atleast_2d(np.asarray(points_camera, dtype=np.float64))
        T = self.base_from_camera
        return p @ T[:3, :3].T + T[:3, 3]

    def project(self, points_base) -> tuple[np.ndarray, np.ndarray]:
        """(N, 3) base-frame points -> pixels (N, 2) and depths (N,) (OpenCV ``projectPoints``)."""
        p = self.to_camera(points_base)
        uv, _ = cv2.projectPoints(p.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), self.K, self.distortion)
        return uv.reshape(-1, 2), p[:, 2]

    def backproject(self, pixels, depth) -> np.ndarray:
        """Pixels (N, 2) with depths (N,) in metres -> base-frame points (N, 3) (OpenCV ``undistortPoints``)."""
        uv = np.atleast_2d(np.asarray(pixels, dtype=np.float64))
        z = np.asarray(depth, dtype=np.float64).reshape(-1)
        xy = cv2.undistortPoints(uv.reshape(-1, 1, 2), self.K, self.distortion).reshape(-1, 2)
        return self.to_base(np.column_stack([xy * z[:, None], z]))

    # -- files --------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {"width": int(self.width), "height": int(self.height), "distortion_model": "plumb_bob",
                "k": self.K.ravel().tolist(), "d": self.distortion.tolist(),
                "base_from_camera": self.base_from_camera.tolist()}

    @classmethod
    def from_dict(cls, data) -> "Camera":
        """Validate a calibration dict (see the module docstring); errors name the field."""
        if not isinstance(data, dict):
            raise ScdpError("camera", f"a calibration is a JSON object, got {type(data).__name__}")
        missing = [k for k in ("width", "height", "k", "base_from_camera") if k not in data]
        if missing:
            raise ScdpError("camera", f"missing {', '.join(missing)}")
        unknown = sorted(set(data) - {"width", "height", "k", "d", "distortion_model", "base_from_camera", "frame_id"})
        if unknown:
            raise ScdpError("camera", f"unknown field(s) {', '.join(unknown)}")
        K = finite_array(data["k"], "k")
        if K.shape not in ((9,), (3, 3)):
            raise ScdpError("k", f"expected 9 numbers (row-major 3x3), got shape {K.shape}")
        K = K.reshape(3, 3)
        if not np.allclose(K[[0, 1, 2, 2], [1, 0, 0, 1]], 0) or K[2, 2] != 1:
            raise ScdpError("k", "must be [fx, 0, cx, 0, fy, cy, 0, 0, 1] (no skew)")
        model = data.get("distortion_model", "plumb_bob")
        if model not in ("plumb_bob", "rational_polynomial", ""):
            raise ScdpError("distortion_model", f"OpenCV models plumb_bob or rational_polynomial, got {model!r}")
        return cls(width=data["width"], height=data["height"], fx=float(K[0, 0]), fy=float(K[1, 1]), cx=float(K[0, 2]),
                   cy=float(K[1, 2]), base_from_camera=data["base_from_camera"], distortion=data.get("d", np.zeros(5)))

    @classmethod
    def load(cls, path) -> "Camera":
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise ScdpError("--camera", f"{path} does not exist") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ScdpError("--camera", f"{path} is not JSON ({exc})") from None
        return cls.from_dict(data)

    def save(self, path) -> Path:
        return write_json(path, self.to_dict())

    @classmethod
    def look_at(cls, eye, target, *, width: int = 640, height: int = 480, fx: float = 615.0, fy: float | None = None,
                cx: float | None = None, cy: float | None = None, up=(0.0, 0.0, 1.0)) -> "Camera":
        """A camera at ``eye`` whose optical axis points at ``target`` (base frame), image ``up`` roughly up.

        Defaults resemble a RealSense D435 colour stream at 640x480 (fx = fy ~ 615 px).
        """
        eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
        z = target - eye
        if np.linalg.norm(z) < 1e-9:
            raise ScdpError("target", "must differ from the camera position")
        z /= np.linalg.norm(z)
        x = np.cross(z, up)
        if np.linalg.norm(x) < 1e-9:
            raise ScdpError("up", "must not be parallel to the viewing direction")
        x /= np.linalg.norm(x)
        y = np.cross(z, x)  # image down
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = np.column_stack([x, y, z]), eye
        return cls(width=width, height=height, fx=fx, fy=fx if fy is None else fy,
                   cx=(width - 1) / 2 if cx is None else cx, cy=(height - 1) / 2 if cy is None else cy, base_from_camera=T)


def block_reach_camera() -> Camera:
    """The fixed camera of the simulated Block Reach cell: in front of the table, 0.75 m up,
    looking at the middle of the block area, at the RealSense-like 640x480 defaults."""
    return Camera.look_at(eye=(1.25, 0.0, 0.75), target=(0.5, 0.0, 0.1))


@functools.lru_cache(maxsize=64)  # a Camera is immutable and checked when built (0.4 ms); observers project often
def viewer_camera(task: Task, width: int = 640, height: int = 480) -> Camera | None:
    """The view of a person watching ``task``'s robot: a camera at the task's ``viewer_eye`` looking
    at its ``viewer_target`` (fx = fy = 560 px at 640 wide, a person's field of view); None for a
    task watched from above (no ``viewer_eye``)."""
    if task.viewer_eye is None:
        return None
    return Camera.look_at(eye=task.viewer_eye, target=task.viewer_target, width=width, height=height,
                          fx=560.0 * width / 640)


def as_seen(task: Task, points) -> np.ndarray:
    """Task-space points (N, d) as the person watching ``task``'s robot sees them: (N, 2) image points
    through :func:`viewer_camera`, or the points themselves for a task watched from above."""
    camera = viewer_camera(task)
    points = np.asarray(points, dtype=np.float64)
    return points if camera is None else camera.project(points)[0]


def observer_camera(width: int = 640, height: int = 480) -> Camera:
    """A person's view of the Block Reach cell (:func:`viewer_camera`): standing across the table from
    the robot (1.7 m in front of its base, eyes 1.05 m up), looking at the arm, which stays whole in
    frame. The view lies in the robot's x-z plane, so a mirror image of the scene (y -> -y) is the
    picture flipped left to right. Used for the pictures people look at: ``scdp deploy``'s strip and
    video, the Block Reach stimuli of ``scdp study``, and the viewpoint observer."""
    return viewer_camera(BLOCK_REACH, width, height)
