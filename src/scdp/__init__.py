"""scdp: Style-Conditioned Diffusion Policy, with the tasks, data, metrics and baselines to reproduce it."""

__version__ = "0.1.0"

from scdp import threads as _threads

# Idle OpenMP threads sleep rather than spin, so scdp degrades gracefully beside other busy
# processes; set before torch is imported, and never over a user's choice (scdp.threads).
_threads.configure()
