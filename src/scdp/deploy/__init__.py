"""The paper's robot path, in simulation: camera -> detected blocks -> plan -> 1 kHz execution.

* :mod:`scdp.deploy.scene`: one scene (:func:`deploy_scene`), its typed :class:`SceneResult`;
* :mod:`scdp.deploy.run`: many scenes into a folder (:func:`deploy_scenes`), the failure policy, the summary;
* :mod:`scdp.deploy.media`: the frames, strip and video of a deployed motion.

Swapping the simulated camera and arm for real ones means implementing
:class:`~scdp.execution.Arm` and a ``capture()`` that returns ``(rgb, depth)`` (docs/deploy.md).
"""

from scdp.deploy.media import motion_frames, strip, write_mp4, write_png
from scdp.deploy.run import FRAME_EVERY_S, DeployRun, deploy_scenes, summarise
from scdp.deploy.scene import SCENE_KEYS, SceneMedia, SceneResult, check_task, deploy_scene, polyline_distance

__all__ = ["FRAME_EVERY_S", "SCENE_KEYS", "DeployRun", "SceneMedia", "SceneResult", "check_task", "deploy_scene",
           "deploy_scenes", "motion_frames", "polyline_distance", "strip", "summarise", "write_mp4", "write_png"]
