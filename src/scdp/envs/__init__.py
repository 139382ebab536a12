"""Gymnasium environments for the two tasks; build them with ``task.make_env()``."""

from scdp.envs.base import GoalReachEnv

__all__ = ["GoalReachEnv"]
