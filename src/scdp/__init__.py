"""scdp: Style-Conditioned Diffusion Policy, with the tasks, data, metrics and baselines to reproduce it."""

__version__ = "0.1.0"

import os as _os

# Idle OpenMP threads sleep rather than spin, so scdp degrades gracefully beside other busy
# processes (see scdp.threads); set before torch is imported, and never over a user's choice.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
