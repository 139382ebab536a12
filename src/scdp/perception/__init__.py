"""From an RGB-D frame to goals in the robot base frame: :class:`Camera` calibration,
:func:`render_rgbd` (the simulated camera), the :class:`Detector` protocol with an OpenCV
:class:`ColorDetector`, and :func:`locate` (docs/deploy.md)."""

from scdp.perception.camera import Camera, block_reach_camera, observer_camera
from scdp.perception.detect import ColorDetector, Detection, Detector, draw_detections
from scdp.perception.locate import locate
from scdp.perception.render import DepthNoise, paint_blocks, render_rgbd

__all__ = ["Camera", "block_reach_camera", "observer_camera", "ColorDetector", "Detection", "Detector", "draw_detections", "locate", "DepthNoise",
           "paint_blocks", "render_rgbd"]
