"""The planner contract: what every policy (DP, SCDP, Legibility Diffuser) offers a rollout.

A planner is called once per chunk for B scenes at once::

    planner.reset()                                   # start of an episode (batch)
    chunk = planner.act(obs, generators)              # obs: Observation of B scenes; one generator per scene
    chunk.actions   # (B, n_action_steps, S) absolute next states to execute, in order
    chunk.styles    # B strings: the style that planned each scene's chunk ("none" for DP/LD)

It observes the last ``planner.n_obs_steps`` states; the rollout builds that history.
Shapes: B scenes, O = n_obs_steps, S state dim, G task-space dim, K goals per scene.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np
import torch

from scdp.tasks import Task


@dataclass
class Observation:
    """What a planner sees at a replanning step, for B scenes.

    state_hist (B, O, S): the last O states, oldest first (the first state repeated at the
    start of an episode). position (B, G): the robot's current task-space point.
    goals (B, K, G): every goal of each scene. target (B,): index of g* in ``goals``.
    """

    state_hist: torch.Tensor
    position: torch.Tensor
    goals: torch.Tensor
    target: torch.Tensor

    @property
    def goal(self) -> torch.Tensor:
        """(B, G): the target g* of each scene."""
        return self.goals[torch.arange(len(self.target), device=self.target.device), self.target]

    def to(self, device) -> Observation:
        """The same observation with every tensor on ``device`` (a planner's, see :mod:`scdp.devices`)."""
        return Observation(*(t.to(device) for t in (self.state_hist, self.position, self.goals, self.target)))


def observe_histories(task: Task, histories, goals, targets, n_obs_steps: int, positions=None) -> Observation:
    """The :class:`Observation` of B scenes from each scene's states so far.

    histories: B sequences of states (T_b >= 1, S), oldest first; the last ``n_obs_steps`` are
    kept, the first state repeated where an episode has fewer. goals (B, K, G), targets (B,).
    positions (B, G) defaults to the task-space point of each last state. The kept states must be
    finite and inside the task's bounds (:meth:`~scdp.tasks.Task.check_states`, field ``state``):
    a planner is never asked to extrapolate from a state no robot can be in.
    """
    hist = np.stack([np.stack([h[max(len(h) - n_obs_steps + k, 0)] for k in range(n_obs_steps)]) for h in histories])
    task.check_states(hist, "state")
    positions = task.task_space(hist[:, -1]) if positions is None else np.asarray(positions)
    return Observation(
        state_hist=torch.as_tensor(hist, dtype=torch.float32),  # (B, O, S)
        position=torch.as_tensor(positions, dtype=torch.float32),  # (B, G)
        goals=torch.as_tensor(np.asarray(goals), dtype=torch.float32),  # (B, K, G)
        target=torch.as_tensor(np.asarray(targets)),  # (B,)
    )


class Chunk(NamedTuple):
    """A planned chunk: actions (B, n_action_steps, S) and the style of each scene; ``plan``
    (B, H, S), the whole denoised horizon as absolute states (what a warm start reuses), each
    scene's legible ``weights`` (B,) and how each scene's sampling began (``starts``: ``warm``, or
    the reason it started cold, :data:`COLD_REASONS`)."""

    actions: torch.Tensor
    styles: list[str]
    plan: torch.Tensor | None = None
    weights: np.ndarray | None = None
    starts: list[str] | None = None


# Why a chunk was denoised from pure noise rather than from the previous plan:
COLD_REASONS = ("off", "first", "style", "jump", "dropped")


@dataclass
class WarmStart:
    """What the previous chunk of each of B scenes leaves for the next (:meth:`from_chunk`).

    plan (B, H, S): the previous plan as absolute states; weights (B,): its legible weights;
    executed: how many of its actions were taken since; cold (B,): a reason to start cold that the
    caller already knows (``first``, ``dropped``), or None. A planner starts a scene warm only when
    none of the rules of :meth:`scdp.policies.diffusion.DiffusionPolicy.warm_rows` says otherwise.
    """

    plan: torch.Tensor | None
    weights: np.ndarray | None
    executed: int
    cold: list[str | None]

    @staticmethod
    def cold_start(batch: int, reason: str = "first") -> "WarmStart":
        return WarmStart(plan=None, weights=None, executed=0, cold=[reason] * batch)

    @staticmethod
    def from_chunk(chunk: Chunk, executed: int) -> "WarmStart":
        return WarmStart(plan=chunk.plan, weights=chunk.weights, executed=executed, cold=[None] * len(chunk.styles))


@runtime_checkable
class Planner(Protocol):
    """Implemented by :class:`~scdp.policies.diffusion.DiffusionPolicy`,
    :class:`~scdp.policies.scdp.StyleConditionedPolicy` and
    :class:`~scdp.policies.legibility_diffuser.LegibilityDiffuser`."""

    @property
    def n_obs_steps(self) -> int:
        """How many past states ``act`` needs in ``Observation.state_hist``."""
        ...

    def reset(self) -> None:
        """Start of an episode: clear any per-episode state."""
        ...

    def act(self, obs: Observation, generator: torch.Generator | list[torch.Generator] | None = None,
            warm: WarmStart | None = None) -> Chunk:
        """Plan the next chunk for every scene of ``obs``; ``generator`` is one CPU generator, or a
        list with one per scene (then a scene's noise does not depend on its batch). ``warm``: the
        previous chunks, to start from (None: cold). ``obs`` may be on any device; the chunk comes
        back on the CPU."""
        ...
