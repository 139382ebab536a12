"""Test doubles shared by the guard tests."""

import numpy as np
import torch

from scdp.policies.base import Chunk


class StubPlanner:
    """A :class:`~scdp.policies.base.Planner` whose chunk for each scene is ``make(state)`` (n, state_dim):
    whatever it returns reaches the caller's last check, which is what the guard tests exercise."""

    n_obs_steps, n_action_steps, n_goals, style_modes, denoiser_parameters = 2, 4, None, (), 0

    def __init__(self, make):
        self.make = make

    def reset(self):
        pass

    def act(self, obs, generator=None):
        states = obs.state_hist[:, -1].double().numpy()
        return Chunk(torch.as_tensor(np.stack([self.make(s) for s in states])), ["none"] * len(states))
