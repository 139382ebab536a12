"""From 2-D detections and a depth image to block centres in the robot base frame.

For each label there must be exactly one detection. Then:

1. The median of the valid depths in the central part of its box (robust to holes, noise and
   the table showing at the box's corners) is the depth of the block's visible surface.
2. The box's valid pixels within a block's size of that depth are the block (only the
   detection's own pixels, when the detector gives a mask: a box may hold part of a block in
   front); each is back-projected with its own depth and taken to the base frame.
3. A block on a table, seen from above, shows its whole top face: the points within a few
   millimetres of the highest span it, the middle of their extent is the face's centre, and the block's centre is half a block
   below it. Where too little of the top face is seen (a camera near table height), the box
   centre back-projected at the median depth is pushed along the viewing ray to the centre.
"""

from __future__ import annotations

import numpy as np

from scdp.errors import ScdpError
from scdp.perception.camera import Camera
from scdp.perception.detect import Detection
from scdp.perception.render import NO_DEPTH
from scdp.robots import panda
from scdp.tasks import BLOCK_REACH

LABELS = ("target", "distractor")
INNER = 0.5  # the depth statistic uses the central half of the box (in each direction)
FACE_BAND = 0.15  # top-face points lie within this many half-sizes of the highest block point
MIN_FACE_PIXELS = 12
WORKSPACE_MARGIN = 0.03  # metres a located block may lie outside the task's workspace box


def valid_depth(depth: np.ndarray, mask: np.ndarray | None) -> np.ndarray:
    """(H, W) bool: finite depth > 0, within the detection's own pixels when it has a mask."""
    ok = np.isfinite(depth) & (depth > NO_DEPTH)
    return ok if mask is None else ok & mask


def box_depth(depth: np.ndarray, box, label: str, mask: np.ndarray | None = None) -> float:
    """Median of the valid depths in the central part of ``box``; refuses a box without any."""
    x0, y0, x1, y1 = box
    h, w = depth.shape
    if not (0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h):
        raise ScdpError("detections", f"{label} box {tuple(box)} is not inside the {w}x{h} depth image")
    mx, my = (x1 - x0) * (1 - INNER) / 2, (y1 - y0) * (1 - INNER) / 2
    rows = slice(int(y0 + my), max(int(np.ceil(y1 - my)), int(y0 + my) + 1))
    cols = slice(int(x0 + mx), max(int(np.ceil(x1 - mx)), int(x0 + mx) + 1))
    valid = depth[rows, cols][valid_depth(depth, mask)[rows, cols]]
    if valid.size == 0:
        raise ScdpError("depth", f"no valid depth inside the {label} box {tuple(box)}")
    return float(np.median(valid))


def surface_to_centre(surface: np.ndarray, camera: Camera, half_size: float) -> np.ndarray:
    """Move a point on an axis-aligned cube's visible surface to its centre, along the viewing ray:
    from the centre, the ray leaves the cube after ``half_size / max|ray_i|`` (base frame)."""
    ray = surface - camera.base_from_camera[:3, 3]
    ray /= np.linalg.norm(ray)
    return surface + ray * half_size / np.max(np.abs(ray))


def block_points(depth: np.ndarray, box, camera: Camera, surface_depth: float, half_size: float,
                 mask: np.ndarray | None = None) -> np.ndarray:
    """Base-frame points (N, 3) of the box's valid pixels within a block's extent of ``surface_depth``."""
    x0, y0, x1, y1 = box
    v, u = np.mgrid[y0:y1, x0:x1]
    d = depth[y0:y1, x0:x1]
    keep = valid_depth(depth, mask)[y0:y1, x0:x1] & (np.abs(d - surface_depth) < 3 * half_size)
    return camera.backproject(np.column_stack([u[keep], v[keep]]).astype(np.float64), d[keep])


def top_face_centre(points: np.ndarray, half_size: float) -> np.ndarray | None:
    """The block centre half a block below the centre of its top face, or None if too little is seen."""
    top = np.percentile(points[:, 2], 95)
    face = points[points[:, 2] > top - FACE_BAND * half_size]
    if len(face) < MIN_FACE_PIXELS:
        return None
    # The middle of the face's extent, not the mean of its points: perspective samples the near
    # half of the face more densely.
    low, high = np.percentile(face[:, :2], [2, 98], axis=0)
    return np.array([*(low + high) / 2, np.median(face[:, 2]) - half_size])


def locate(detections: list[Detection], depth: np.ndarray, camera: Camera, *, labels=LABELS,
           half_size: float = panda.BLOCK_HALF_SIZE, workspace=(BLOCK_REACH.workspace_low, BLOCK_REACH.workspace_high),
           margin: float = WORKSPACE_MARGIN) -> np.ndarray:
    """Base-frame centres (len(labels), 3) of the blocks, in the order of ``labels``.

    Raises :class:`ScdpError` (never a made-up goal) when a label has no detection or more than
    one, a box holds no valid depth, or a located block lies more than ``margin`` outside the
    ``workspace`` box (low, high), which means a wrong detection or a wrong calibration.
    """
    depth = np.asarray(depth)
    if depth.ndim != 2 or depth.shape != (camera.height, camera.width):
        raise ScdpError("depth", f"expected a {camera.height}x{camera.width} depth image, got shape {depth.shape}")
    low, high = (np.asarray(v, dtype=np.float64) for v in workspace)
    goals = []
    for label in labels:
        mine = [d for d in detections if d.label == label]
        if not mine:
            raise ScdpError("detections", f"no {label} block found")
        if len(mine) > 1:
            raise ScdpError("detections", f"{len(mine)} detections labelled {label!r}; expected exactly one")
        box, mask = mine[0].box, mine[0].mask
        if mask is not None and np.shape(mask) != depth.shape:
            raise ScdpError("detections", f"the {label} mask has shape {np.shape(mask)}, the depth image {depth.shape}")
        z = box_depth(depth, box, label, mask)
        goal = top_face_centre(block_points(depth, box, camera, z, half_size, mask), half_size)
        if goal is None:
            centre_px = np.array([[(box[0] + box[2] - 1) / 2, (box[1] + box[3] - 1) / 2]])
            goal = surface_to_centre(camera.backproject(centre_px, [z])[0], camera, half_size)
        if np.any(goal < low - margin) or np.any(goal > high + margin):
            raise ScdpError("detections", f"the {label} block was located at {np.round(goal, 3).tolist()}, outside the "
                                          f"workspace {low.tolist()}..{high.tolist()} (wrong detection or calibration?)")
        goals.append(goal)
    return np.array(goals)
