"""An example robot defined outside scdp: a planar 3-link arm (docs/tasks.md).

Use it from the folder holding ``examples/`` as ``scdp generate --task examples.planar_arm:TASK ...``,
or ``pip install -e examples/planar_arm`` and then ``--task planar_arm`` (entry point group ``scdp.tasks``).
"""

from .env import PlanarArmEnv
from .task import PLANAR_ARM, TASK, PlanarArmTask

__all__ = ["PLANAR_ARM", "TASK", "PlanarArmEnv", "PlanarArmTask"]
