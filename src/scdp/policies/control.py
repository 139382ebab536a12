"""The control-loop policy: one robot, one scene, one action per control step.

Planners plan chunks for a batch of scenes (:mod:`scdp.policies.base`). A robot's control loop
wants the interface robot-learning libraries use instead: reset at the start of an episode, then
ask for the next action at every step, with the chunk planned when the queue of planned actions
runs dry::

    policy = ControlLoopPolicy.load("runs/cpu/navigation/checkpoints", task, goals, target)  # scdp, real-time
    policy.reset(state)                       # the robot's state at the start
    while not done:
        action = policy.select_action(state)  # (S,): the next absolute state to command
        state = robot.step(action)
    policy.set_style("legible")               # SCDP: takes effect at the next action
    policy.drop_queued_actions()              # replan at the next call, e.g. after a goal moved

Every chunk is planned from the last ``n_obs_steps`` states this object was given, with one
generator seeded once per episode: the same seed plans the same chunks as
:func:`scdp.evaluation.rollout.rollout` and ``scdp deploy`` do for that scene.

This object owns the warm start (:mod:`scdp.policies.diffusion`, when the planner's base has
``warm_skip`` > 0): it keeps the previous chunk, hands it to the planner, and starts cold at the
first chunk of an episode and after :meth:`drop_queued_actions` or :meth:`set_style`; the planner
adds the style and state rules. :attr:`starts` counts how every chunk began.
"""

from __future__ import annotations

from collections import Counter, deque

import numpy as np
import torch

from scdp.config import PlanningOptions
from scdp.errors import ScdpError
from scdp.keys import STYLE_MODES
from scdp.policies.base import Chunk, Planner, WarmStart, act, observe_histories
from scdp.policies.loaders import load_method
from scdp.tasks import Task


def plan_chunks(planner: Planner, task: Task, histories, goals, targets, generators, positions=None,
                warm: WarmStart | None = None, chunk_index=None) -> Chunk:
    """One chunk for each of B robots from its states so far, ``actions`` as (B, n_action_steps, S)
    float64 absolute next states. The one place a state history becomes a chunk, for this object
    (B = 1, with its warm start) and for the planning service (B requests batched into one call,
    each with its ``chunk_index``)."""
    obs = observe_histories(task, histories, goals, targets, planner.n_obs_steps, positions, chunk_index)
    with torch.inference_mode():
        chunk = act(planner, obs, list(generators), warm)
    return chunk._replace(actions=chunk.actions.double().numpy(), styles=list(chunk.styles))


class ControlLoopPolicy:
    """A planner (any runtime) driving one robot in one scene of ``goals`` (K, G) toward ``goals[target]``."""

    def __init__(self, planner: Planner, task: Task, goals, target: int, *, seed: int = 0):
        self.planner, self.task = planner, task
        self.goals = task.validate_goals(goals, target)
        self.target, self.seed = int(target), int(seed)
        self.n_obs_steps = planner.n_obs_steps
        self.history: list[np.ndarray] = []
        self.queue: deque = deque()
        self.styles: list[str] = []  # the style of every chunk planned this episode
        self.generator = torch.Generator().manual_seed(self.seed)
        self.last: Chunk | None = None  # the previous chunk (the warm start's source)
        self.cold: str | None = "first"  # a reason the next chunk must start cold
        self.starts: Counter = Counter()  # how every chunk began: "warm", or its cold reason

    @classmethod
    def load(cls, checkpoints, task: Task, goals, target: int, *, method="scdp", planning: PlanningOptions | None = None,
             seed: int = 0) -> ControlLoopPolicy:
        """A policy around ``method`` loaded from ``checkpoints``; ``planning`` defaults to the control
        loop's entry (:data:`scdp.config.planning.ENTRY_PROFILES`: the real-time planner)."""
        planning = PlanningOptions.of_entry("control_loop") if planning is None else planning
        return cls(load_method(method, checkpoints, task, planning), task, goals, target, seed=seed)

    def reset(self, state=None) -> None:
        """A new episode: no history, nothing queued, the planner's per-episode state and the noise
        generator back to their start. ``state`` (S,) is the first observation, when known."""
        self.history, self.styles = [], []
        self.last, self.cold, self.starts = None, "first", Counter()
        self.queue.clear()
        self.planner.reset()
        self.generator = torch.Generator().manual_seed(self.seed)
        if state is not None:
            self._observe(state)

    def _observe(self, state) -> None:
        state = np.asarray(state, dtype=np.float64)
        if state.shape != (self.task.state_dim,):
            raise ScdpError("state", f"expected {self.task.state_dim} numbers, got shape {state.shape}")
        if not self.history or not np.array_equal(self.history[-1], state):  # a control step repeats its state
            self.history.append(state)

    def observe(self, states) -> None:
        """Append states (T, S) the robot went through, oldest first (e.g. the states it reached at
        each waypoint of a chunk); every one is kept, repeats included."""
        states = np.asarray(states, dtype=np.float64).reshape(-1, self.task.state_dim)
        self.history.extend(states)

    def predict_action_chunk(self, state=None, position=None) -> np.ndarray:
        """Plan a chunk from ``state`` (None: the last state observed) and the states before it:
        (n_action_steps, S) absolute next states, in order. ``position`` (G,) is the robot's measured
        task-space point (default: the task's kinematics of the state). The queue is left as it is;
        a chunk that is not finite is refused on ``actions``."""
        if state is not None:
            self._observe(state)
        if not self.history:
            raise ScdpError("state", "no state observed yet: pass the robot's state, or reset(state) first")
        positions = None if position is None else [np.asarray(position, dtype=np.float64)]
        if self.last is None or self.cold:
            warm = WarmStart.cold_start(1, self.cold or "first")
        else:  # the previous chunk's actions were all taken (a partial one is dropped, and starts cold)
            warm = WarmStart.from_chunk(self.last, executed=len(self.last.actions[0]))
        planned = plan_chunks(self.planner, self.task, [self.history], [self.goals], [self.target], [self.generator],
                              positions, warm)
        self.last, self.cold = planned, None
        self.starts[(planned.starts or ["off"])[0]] += 1
        self.styles.append(planned.styles[0])
        chunk = planned.actions[0]
        if not np.all(np.isfinite(chunk)):
            k = int(np.argmin(np.isfinite(chunk).all(axis=1)))
            raise ScdpError("actions", f"step {k} of the chunk planned after {len(self.history)} states contains "
                                       "NaN or inf; nothing was queued or executed")
        return chunk

    def select_action(self, state) -> np.ndarray:
        """The next action (S,) from ``state``: the next queued one, planning a chunk when none is left."""
        self._observe(state)
        if not self.queue:
            self.queue.extend(self.predict_action_chunk(state))
        return self.queue.popleft()

    def set_goals(self, goals, target: int) -> int:
        """The scene changed (a goal appeared, vanished or moved): plan for ``goals`` (K, G) and
        ``goals[target]`` from now on. The actions queued for the old scene are dropped (returned: how
        many) and the next chunk starts cold, saying why (``goals``). The same goals again change nothing."""
        goals = self.task.validate_goals(goals, target)
        if int(target) == self.target and np.array_equal(goals, self.goals):
            return 0
        self.goals, self.target = goals, int(target)
        dropped = len(self.queue)
        self.queue.clear()
        self.cold = "goals"  # the last plan was for another scene
        return dropped

    def drop_queued_actions(self) -> int:
        """Forget the actions planned but not yet taken (the next call replans); returns how many."""
        dropped = len(self.queue)
        self.queue.clear()
        self.cold = "dropped"  # the plan no longer matches what the robot will do
        return dropped

    def set_style(self, style: str) -> None:
        """Switch an SCDP planner's style mode (``auto``, ``blend``, ``legible``, ``efficient``,
        ``none``) and drop the queue, so the next action already has the new style."""
        if style not in STYLE_MODES:
            raise ScdpError("style", f"one of {', '.join(STYLE_MODES)}, got {style!r}")
        self.planner.set_style(style)  # refused by a planner without styles, or without that style's predictors
        self.drop_queued_actions()
        self.cold = "style"  # a style flip always starts cold
