"""A planner that lives outside ``src/``: it steps straight at the target, a fixed distance per
action. Registered with :func:`scdp.planners.register`, it runs through ``scdp evaluate`` with no
file of scdp touched (tests/test_planner_registry.py); docs/planners.md walks through the same."""

from __future__ import annotations

import torch

from scdp.errors import ScdpError
from scdp.planners import PlannerKind, register, unregister
from scdp.policies.base import Chunk, Observation

NAME = "straight"


class StraightLine:
    """Each action moves the robot's task-space point ``step`` metres towards the target g*."""

    n_obs_steps, n_action_steps, n_goals, style_modes, denoiser_parameters = 1, 8, None, (), 0

    def __init__(self, task, step: float = 0.02):
        self.task, self.step = task, step

    def set_style(self, style: str) -> None:
        raise ScdpError("style", f"{NAME} has no styles")

    def reset(self) -> None:
        pass

    def act(self, obs: Observation, generator=None, warm=None) -> Chunk:
        state = obs.state_hist[:, -1].clone()  # (B, S)
        states = []
        for _ in range(self.n_action_steps):
            point = torch.as_tensor(self.task.task_space(state.numpy()), dtype=torch.float32)  # (B, G)
            heading = obs.goal - point
            move = heading * torch.clamp(self.step / heading.norm(dim=1, keepdim=True).clamp_min(1e-9), max=1.0)
            state = state.clone()
            state[:, : point.shape[1]] += move  # the point is the state's first coordinates (navigation)
            states.append(state)
        return Chunk(actions=torch.stack(states, dim=1), styles=["none"] * len(state))


def load_straight(spec, checkpoints, task, planning, **options) -> StraightLine:
    return StraightLine(task)


def registered() -> PlannerKind:
    return register(PlannerKind(NAME, family=NAME, parts=(), denoiser=None, load=load_straight), replace=True)


def removed() -> None:
    unregister(NAME)
