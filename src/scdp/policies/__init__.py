"""Policies: the goal-conditioned Diffusion Policy, SCDP on top of it, and Legibility Diffuser."""
