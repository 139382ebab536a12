"""scdp: Style-Conditioned Diffusion Policy, with the tasks, data, metrics and baselines to reproduce it."""

__version__ = "0.1.0"
