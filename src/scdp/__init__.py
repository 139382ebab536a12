"""scdp: Style-Conditioned Diffusion Policy, with the tasks, data, metrics and baselines to reproduce it."""

__version__ = "0.1.0"

import os as _os

from scdp import threads as _threads

# Offscreen rendering (scdp.perception) without a display needs EGL; MuJoCo reads this when it
# is first imported, so it is set here, never over a user's choice.
if not _os.environ.get("DISPLAY") and not _os.environ.get("MUJOCO_GL"):
    _os.environ["MUJOCO_GL"] = "egl"

# Idle OpenMP threads sleep rather than spin, so scdp degrades gracefully beside other busy
# processes; set before torch is imported, and never over a user's choice (scdp.threads).
_threads.configure()
