"""The pictures of a deployment: camera frames along the executed motion, a strip, a video.

Drawn from a scene's :class:`~scdp.deploy.scene.SceneMedia` (``deploy_scene(..., keep_samples=True)``);
PNG and MP4 are written through OpenCV.
"""

from __future__ import annotations

import cv2
import numpy as np

from scdp.deploy.scene import SceneMedia
from scdp.errors import ScdpError
from scdp.perception import Camera, render_rgbd


def motion_frames(media: SceneMedia, camera: Camera, every_s: float) -> list[np.ndarray]:
    """Camera frames of a kept deployment (``keep_samples=True``), one per ``every_s`` seconds of
    motion, the detections drawn on the first."""
    sim, measured = media.sim, media.measured
    ticks = np.unique(np.append(np.arange(0, len(measured), max(1, round(every_s * sim.rate))), len(measured) - 1))
    frames = [media.first_frame]
    for t in ticks[1:]:
        sim.data.qpos[:7] = measured[t]
        frames.append(render_rgbd(sim, camera)[0])
    return frames


def strip(frames: list[np.ndarray], count: int = 5, scale: float = 0.5) -> np.ndarray:
    """``count`` frames evenly along the motion side by side (the paper's real-robot figure)."""
    picks = np.linspace(0, len(frames) - 1, min(count, len(frames))).round().astype(int)
    small = [cv2.resize(frames[i], None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) for i in picks]
    return cv2.hconcat(small)


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
