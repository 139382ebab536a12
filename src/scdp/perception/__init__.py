"""From an RGB-D frame to goals in the robot base frame: :class:`Camera` calibration,
:func:`render_rgbd` (the simulated camera), the :class:`Detector` protocol with an OpenCV
:class:`ColorDetector`, and :func:`locate` (docs/deploy.md)."""

from scdp.perception.camera import Camera, as_seen, block_reach_camera, observer_camera, viewer_camera
from scdp.perception.detect import ColorDetector, Detection, Detector, draw_detections
from scdp.perception.locate import locate
from scdp.perception.render import DepthNoise, paint_blocks, render_rgb, render_rgbd

__all__ = ["Camera", "as_seen", "block_reach_camera", "observer_camera", "viewer_camera", "ColorDetector", "Detection", "Detector",
           "draw_detections", "locate", "DepthNoise", "paint_blocks", "render_rgb", "render_rgbd"]
