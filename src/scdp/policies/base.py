"""The planner contract: what every policy (DP, SCDP, Legibility Diffuser) offers a rollout.

A planner is called once per chunk for B scenes at once::

    planner.reset()                                   # start of an episode (batch)
    chunk = planner.act(obs, generators)              # obs: Observation of B scenes; one generator per scene
    chunk.actions   # (B, n_action_steps, S) absolute next states to execute, in order
    chunk.styles    # B strings: the style that planned each scene's chunk ("none" for DP/LD)

It observes the last ``planner.n_obs_steps`` states; the rollout builds that history.
Shapes: B scenes, O = n_obs_steps, S state dim, G task-space dim, K goals per scene.

Timing, as Diffusion Policy counts it (one row per control step t; a chunk is planned at t)::

    step        t-O+1 ... t-1   t          t+1 ... t+n_action_steps     ... t-O+horizon
    state_hist  observed ...    observed   -                                 -
    plan rows   0 ...           O-2        O-1 ... O-2+n_action_steps       ... horizon-1
    executed    -               -          yes (n_action_steps actions)      no (replanned)

Besides ``act`` and ``reset``, a planner says what its callers need without reaching into it:
``n_action_steps``, ``n_goals`` (:func:`check_scene_goals` is the one check of a scene's goal
count), ``style_modes`` and ``denoiser_parameters``.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np
import torch

from scdp.errors import ScdpError
from scdp.tasks import Task


@dataclass
class Observation:
    """What a planner sees at a replanning step, for B scenes.

    state_hist (B, O, S): the last O states, oldest first (the first state repeated at the
    start of an episode). position (B, G): the robot's current task-space point.
    goals (B, K, G): every goal of each scene. target (B,): index of g* in ``goals``.
    chunk_index (B,) or None: how many chunks each scene's episode has executed, for a caller
    that keeps no planner per episode (the service); Legibility Diffuser's guidance decay reads it.
    """

    state_hist: torch.Tensor
    position: torch.Tensor
    goals: torch.Tensor
    target: torch.Tensor
    chunk_index: torch.Tensor | None = None

    @property
    def goal(self) -> torch.Tensor:
        """(B, G): the target g* of each scene."""
        return self.goals[torch.arange(len(self.target), device=self.target.device), self.target]

    def to(self, device) -> Observation:
        """The same observation with every tensor on ``device`` (a planner's, see :mod:`scdp.devices`)."""
        return Observation(*(t.to(device) for t in (self.state_hist, self.position, self.goals, self.target)),
                           chunk_index=None if self.chunk_index is None else self.chunk_index.to(device))


def observe_histories(task: Task, histories, goals, targets, n_obs_steps: int, positions=None,
                      chunk_index=None) -> Observation:
    """The :class:`Observation` of B scenes from each scene's states so far.

    histories: B sequences of states (T_b >= 1, S), oldest first; the last ``n_obs_steps`` are
    kept, the first state repeated where an episode has fewer. goals (B, K, G), targets (B,).
    positions (B, G) defaults to the task-space point of each last state. The kept states must be
    finite and inside the task's bounds (:meth:`~scdp.tasks.Task.check_states`, field ``state``):
    a planner is never asked to extrapolate from a state no robot can be in. ``chunk_index`` (B,):
    see :class:`Observation`.
    """
    hist = np.stack([np.stack([h[max(len(h) - n_obs_steps + k, 0)] for k in range(n_obs_steps)]) for h in histories])
    task.check_states(hist, "state")
    positions = task.task_space(hist[:, -1]) if positions is None else np.asarray(positions)
    return Observation(
        state_hist=torch.as_tensor(hist, dtype=torch.float32),  # (B, O, S)
        position=torch.as_tensor(positions, dtype=torch.float32),  # (B, G)
        goals=torch.as_tensor(np.asarray(goals), dtype=torch.float32),  # (B, K, G)
        target=torch.as_tensor(np.asarray(targets)),  # (B,)
        chunk_index=None if chunk_index is None else torch.as_tensor(np.asarray(chunk_index)),  # (B,)
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
COLD_REASONS = ("off", "first", "style", "jump", "dropped", "goals")  # goals: the scene changed since the last plan


@dataclass
class WarmStart:
    """What the previous chunk of each of B scenes leaves for the next (:meth:`from_chunk`).

    plan (B, H, S): the previous plan as absolute states; weights (B,): its legible weights;
    executed: how many of its actions were taken since; cold (B,): a reason to start cold that the
    caller already knows (``first``, ``dropped``), or None. A planner starts a scene warm only when
    none of the rules of :meth:`scdp.policies.diffusion.DiffusionPolicy.warm_starts` says otherwise.
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

    @staticmethod
    def of_scenes(plans: list, weights: list, executed: int, cold: list | None = None) -> "WarmStart":
        """The one builder of a batch's warm start from what each of B scenes planned last: ``plans[b]``
        its previous plan (H, S) absolute states, or None (cold: ``cold[b]`` says why, by default
        ``first``), ``weights[b]`` that plan's legible weight (None: planned without a style). Used by
        the rollouts and the service."""
        why = [(cold[b] if cold is not None and cold[b] else "first") for b in range(len(plans))]
        known = [p is not None for p in plans]
        if not any(known):
            return WarmStart(plan=None, weights=None, executed=0, cold=why)
        like = np.asarray(plans[known.index(True)], dtype=np.float32)
        blank = np.zeros_like(like)  # a cold row's plan is never read
        plan = torch.as_tensor(np.stack([blank if p is None else np.asarray(p, dtype=np.float32) for p in plans]))
        style = None
        if any(w is not None for w in weights):
            style = np.array([np.nan if w is None else float(w) for w in weights])
        return WarmStart(plan=plan, weights=style, executed=executed, cold=[None if k else w for k, w in zip(known, why)])


@runtime_checkable
class Planner(Protocol):
    """Implemented by :class:`~scdp.policies.diffusion.DiffusionPolicy`,
    :class:`~scdp.policies.scdp.StyleConditionedPolicy` and
    :class:`~scdp.policies.legibility_diffuser.LegibilityDiffuser`."""

    @property
    def n_obs_steps(self) -> int:
        """How many past states ``act`` needs in ``Observation.state_hist``."""
        ...

    @property
    def n_action_steps(self) -> int:
        """How many actions a chunk holds."""
        ...

    @property
    def n_goals(self) -> int | None:
        """The goal count a scene must have (SCDP: its scene encoder's), or None for any."""
        ...

    @property
    def style_modes(self) -> tuple[str, ...]:
        """The style modes :meth:`set_style` takes (SCDP: those its loaded predictors allow; else none)."""
        ...

    def set_style(self, style: str) -> None:
        """Plan every chunk from the next one on in style mode ``style``, one of :attr:`style_modes`;
        a planner without styles refuses (``ScdpError`` on ``style``)."""
        ...

    @property
    def denoiser_parameters(self) -> int:
        """Parameters of the denoising network it samples from (to size the thread pool)."""
        ...

    def reset(self) -> None:
        """Start of an episode: clear any per-episode state."""
        ...

    def act(self, obs: Observation, generator: torch.Generator | list[torch.Generator] | None = None,
            warm: WarmStart | None = None) -> Chunk:
        """Plan the next chunk for every scene of ``obs``; ``generator`` is one CPU generator, or a
        list with one per scene (then a scene's noise does not depend on its batch). ``warm``: the
        previous chunks, to start from (None: cold). ``obs`` may be on any device; the chunk comes
        back on the CPU. Part of the contract: an ``act(obs, generator)`` without ``warm``, written
        before warm starts, is accepted by :func:`act` and always plans cold."""
        ...


def trained_goal_count(planners) -> int | None:
    """The goal count every planner of ``planners`` needs (None: any); refused when they disagree."""
    counts = {p.n_goals for p in planners if p.n_goals is not None}
    if len(counts) > 1:
        raise ScdpError("--checkpoints", f"the planners' scene encoders disagree on the goal count: {sorted(counts)}")
    return counts.pop() if counts else None


def check_scene_goals(trained: int | None, n_goals: int, field: str) -> None:
    """The one refusal of a scene whose goal count the scene encoder was not trained for."""
    if trained is not None and n_goals != trained:
        raise ScdpError(field, f"the scene encoder was trained for {trained} goals, got {n_goals}")


def act(planner: Planner, obs: Observation, generator, warm: WarmStart | None = None) -> Chunk:
    """``planner.act``, handing it ``warm`` when its ``act`` takes one: a planner written before warm
    starts (``act(obs, generator)``) still plans, always cold; a plain ``(actions, styles)`` tuple
    becomes a :class:`Chunk`."""
    if "warm" in inspect.signature(planner.act).parameters:
        out = planner.act(obs, generator, warm=warm)
    else:
        out = planner.act(obs, generator)
    return out if isinstance(out, Chunk) else Chunk(*out)

