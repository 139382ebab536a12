"""Finding the blocks in a colour image: the :class:`Detector` protocol and an OpenCV colour detector.

Any detector plugs in by having one method::

    class MyYolo:                                  # e.g. a YOLO fine-tuned on your blocks
        def detect(self, rgb):                     # rgb: (H, W, 3) uint8, RGB order
            boxes = self.model(rgb)                # your model, your dependencies
            return [Detection(label, (x0, y0, x1, y1), score) for ...]

A detector that segments may also fill ``Detection.mask``. Labels are the roles :func:`~scdp.perception.locate.locate` asks for (``"target"`` and
``"distractor"`` by default); boxes are pixel corners ``(x0, y0, x1, y1)`` with ``x1, y1``
exclusive. scdp does not depend on any detection model.
"""  # noqa: E501 (docstring text kept byte-identical)

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import cv2
import numpy as np

from scdp.errors import ScdpError


@dataclass(frozen=True)
class Detection:
    """One object in an image: its label, box (x0, y0, x1, y1) in pixels and a score in [0, 1].

    ``mask`` (optional, (H, W) bool over the whole image) marks the object's own pixels, as a
    segmenting detector gives them; :func:`~scdp.perception.locate.locate` then ignores the
    pixels of anything else inside the box (a block partly in front of another).
    """

    label: str
    box: tuple[int, int, int, int]
    score: float
    mask: np.ndarray | None = field(default=None, compare=False, repr=False)


@runtime_checkable
class Detector(Protocol):
    def detect(self, rgb: np.ndarray) -> list[Detection]:
        """Detections in an (H, W, 3) uint8 RGB image."""
        ...


def check_rgb(rgb) -> np.ndarray:
    """``rgb`` as an (H, W, 3) uint8 array, or a :class:`ScdpError` naming what is wrong."""
    if not isinstance(rgb, np.ndarray) or rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
        shape = getattr(rgb, "shape", None)
        raise ScdpError("rgb", f"expected an (H, W, 3) uint8 image, got {type(rgb).__name__} {getattr(rgb, 'dtype', '')} {shape}")
    if rgb.shape[0] < 2 or rgb.shape[1] < 2:
        raise ScdpError("rgb", f"image of {rgb.shape[1]}x{rgb.shape[0]} pixels is too small")
    return rgb


@dataclass(frozen=True)
class HueRange:
    """An OpenCV HSV box: hue in 0..179 (degrees / 2), saturation and value in 0..255."""

    hue: tuple[int, int]
    min_saturation: int = 90
    min_value: int = 40


# The simulated cell's block colours (scdp.perception.render.TARGET_RGBA / DISTRACTOR_RGBA).
DEFAULT_COLORS = {"target": HueRange((45, 80)), "distractor": HueRange((100, 125))}


class ColorDetector:
    """Blocks of known colours: HSV threshold, morphological opening, connected components.

    Every component of at least ``min_area`` pixels becomes a detection with its bounding box;
    the score is the fraction of the box the component fills. Two blocks of one colour give two
    detections (which :func:`locate` then refuses), never a merged one.
    """

    def __init__(self, colors: dict[str, HueRange] | None = None, *, min_area: int = 40):
        self.colors = dict(DEFAULT_COLORS if colors is None else colors)
        if not self.colors:
            raise ScdpError("colors", "need at least one label")
        self.min_area = int(min_area)
        self._kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3))

    def detect(self, rgb: np.ndarray) -> list[Detection]:
        hsv = cv2.cvtColor(check_rgb(rgb), cv2.COLOR_RGB2HSV)
        found = []
        for label, r in self.colors.items():
            mask = cv2.inRange(hsv, (r.hue[0], r.min_saturation, r.min_value), (r.hue[1], 255, 255))
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, self._kernel)
            n, components, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
            for k, (x, y, w, h, area) in enumerate(stats[1:], start=1):  # component 0 is the background
                if area >= self.min_area:
                    found.append(Detection(label, (int(x), int(y), int(x + w), int(y + h)), float(area) / float(w * h),
                                           mask=components == k))
        return found


def draw_detections(rgb: np.ndarray, detections: list[Detection]) -> np.ndarray:
    """A copy of ``rgb`` with each detection's box, label and score drawn on it."""
    out = check_rgb(rgb).copy()
    for d in detections:
        x0, y0, x1, y1 = d.box
        cv2.rectangle(out, (x0, y0), (x1 - 1, y1 - 1), (255, 255, 0), 2)
        cv2.putText(out, f"{d.label} {d.score:.2f}", (x0, max(y0 - 6, 12)), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 0), 1,
                    cv2.LINE_AA)
    return out
