"""The pictures of a deployment: frames along the executed motion, a strip, a video.

The frames are what a person standing across the table sees (:func:`scdp.perception.observer_camera`):
the whole arm, with the TCP's path so far traced on the image. (The detection camera's own
frame, with its detections drawn, is written beside them.) Drawn from a scene's
:class:`~scdp.deploy.scene.SceneMedia` (``deploy_scene(..., keep_samples=True)``); PNG and MP4
are written through OpenCV.
"""

from __future__ import annotations

import cv2
import mujoco
import numpy as np

from scdp.deploy.scene import SceneMedia
from scdp.errors import ScdpError
from scdp.perception import Camera, observer_camera, render_rgb
from scdp.robots.panda_meshes import arm_words

PATH_RGB = (255, 140, 0)  # the traced TCP path: orange, apart from the blocks' green and blue


def render_poses(scene, joint_path, camera: Camera) -> tuple[list[np.ndarray], np.ndarray]:
    """``scene`` (a MuJoCo model and data of :func:`scdp.robots.panda.mjcf`) posed at each row of
    ``joint_path`` (N, 7) and seen by ``camera``: the N colour frames and the TCP's (N, 3) base-frame
    positions."""
    frames, tcp = [], []
    for q in np.asarray(joint_path, dtype=np.float64):
        scene.data.qpos[:7] = q
        frames.append(render_rgb(scene, camera))  # forwards the kinematics first
        tcp.append(scene.data.site("tcp").xpos.copy())
    return frames, np.array(tcp).reshape(-1, 3)


def tcp_positions(scene, joint_path) -> np.ndarray:
    """The TCP's (N, 3) base-frame positions with ``scene`` posed at each row of ``joint_path`` (N, 7):
    forward kinematics only, no rendering (a traced path needs many more points than a video has frames)."""
    tcp = []
    for q in np.asarray(joint_path, dtype=np.float64):
        scene.data.qpos[:7] = q
        mujoco.mj_kinematics(scene.model, scene.data)
        tcp.append(scene.data.site("tcp").xpos.copy())
    return np.array(tcp).reshape(-1, 3)


def draw_path(rgb: np.ndarray, camera: Camera, points_base, color=PATH_RGB) -> np.ndarray:
    """A copy of ``rgb`` with the base-frame polyline ``points_base`` (N, 3) projected and drawn on it."""
    out = rgb.copy()
    pixels, depth = camera.project(np.asarray(points_base, dtype=np.float64).reshape(-1, 3))
    pts = np.round(pixels[depth > 0]).astype(np.int32)
    thickness = max(2, round(rgb.shape[1] / 200))
    if len(pts) > 1:
        cv2.polylines(out, [pts.reshape(-1, 1, 2)], False, color, thickness, lineType=cv2.LINE_AA)
    if len(pts):
        cv2.circle(out, tuple(int(v) for v in pts[-1]), thickness + 2, color, -1, lineType=cv2.LINE_AA)
    return out


def motion_frames(media: SceneMedia, every_s: float, camera: Camera | None = None) -> list[np.ndarray]:
    """Frames of a kept deployment (``keep_samples=True``) from a person's view (``camera``, by
    default :func:`~scdp.perception.observer_camera`), one per ``every_s`` seconds of motion, each
    with the TCP's path up to that moment traced on it (at the 1 kHz samples, not the frames)."""
    sim, measured = media.sim, media.measured
    camera = camera or observer_camera()
    step = max(1, round(every_s * sim.rate))
    ticks = np.unique(np.append(np.arange(0, len(measured), step), len(measured) - 1))
    tcp = tcp_positions(sim, measured[:: max(1, step // 20)])  # the trace: 20 points per frame
    frames, _ = render_poses(sim, measured[ticks], camera)
    per_point = max(1, step // 20)
    return [draw_path(frame, camera, np.vstack([tcp[:t // per_point + 1], tcp_positions(sim, measured[t:t + 1])]))
            for frame, t in zip(frames, ticks)]


def strip(frames: list[np.ndarray], count: int = 5, scale: float = 0.5) -> np.ndarray:
    """``count`` frames evenly along the motion side by side (the paper's real-robot figure)."""
    picks = np.linspace(0, len(frames) - 1, min(count, len(frames))).round().astype(int)
    small = [cv2.resize(frames[i], None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) for i in picks]
    return cv2.hconcat(small)


def arm_caption(media: SceneMedia) -> str:
    """How the deployed scene's pictures draw the arm (its meshes, or capsules where they are absent)."""
    return arm_words(media.sim.model)


def captioned(rgb: np.ndarray, text: str) -> np.ndarray:
    """``rgb`` over a white band holding ``text``, so the picture says what it shows."""
    height = max(18, rgb.shape[0] // 16)
    band = np.full((height, rgb.shape[1], 3), 255, dtype=np.uint8)
    font = cv2.FONT_HERSHEY_SIMPLEX
    width = cv2.getTextSize(text, font, 1.0, 1)[0][0]
    scale = min(height / 40, (rgb.shape[1] - 12) / width)  # the words fit the band's width
    cv2.putText(band, text, (6, int(height * 0.7)), font, scale, (40, 40, 40), 1, cv2.LINE_AA)
    return cv2.vconcat([rgb, band])


def write_png(path, rgb: np.ndarray) -> None:
    ok, data = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    if not ok:
        raise ScdpError("--out", f"could not encode {path}")
    with open(path, "wb") as f:
        f.write(data.tobytes())


def write_mp4(path, frames: list[np.ndarray], fps: float) -> bool:
    """MP4 (MPEG-4 part 2) through OpenCV's FFmpeg backend; False where this OpenCV cannot write one."""
    h, w = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
    if not writer.isOpened():
        return False
    for f in frames:
        writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    writer.release()
    return True
