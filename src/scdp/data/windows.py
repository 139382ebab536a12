"""Training batches cut from demonstrations (and random scenes for the scene encoder).

For every step ``t`` of every episode there is one window: observations at
``t - O + 1 .. t`` and actions at ``t - O + 1 .. t - O + H`` (O = n_obs_steps,
H = horizon), clamped to the episode, so the first state is repeated before the start and
the final action (holding the goal) after the end — Diffusion Policy's padding. All index
tables are built once; ``get`` is a single gather per array.

Shapes: B batch, O observed steps, H horizon, S state dim, G goal (task-space) dim, K goals.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import torch

from scdp.data.scenes import ENCODER, sample_scenes
from scdp.tasks import Task


@dataclass
class TrainBatch:
    """A batch of demo windows, raw (unscaled) values.

    obs_state (B, O, S), obs_position (B, O, G) task-space points of those states,
    action (B, H, S) absolute next states, goal (B, G) the target g*, goals (B, K, G) every
    goal of the scene, target (B,) the index of g* in ``goals``.
    """

    obs_state: torch.Tensor
    obs_position: torch.Tensor
    action: torch.Tensor
    goal: torch.Tensor
    goals: torch.Tensor
    target: torch.Tensor

    def to(self, device) -> TrainBatch:
        return TrainBatch(**{f.name: getattr(self, f.name).to(device) for f in fields(self)})


@dataclass
class SceneBatch:
    """A batch of scenes: goals (B, K, G) and target (B,)."""

    goals: torch.Tensor
    target: torch.Tensor

    def to(self, device) -> SceneBatch:
        return SceneBatch(self.goals.to(device), self.target.to(device))


class WindowData:
    """Every window of a :class:`~scdp.data.dataset.DemoDataset`; ``get(idx) -> TrainBatch``."""

    def __init__(self, dataset, n_obs_steps: int, horizon: int, task: Task):
        starts = np.concatenate([[0], dataset.episode_ends[:-1]])
        ends = dataset.episode_ends
        lengths = ends - starts
        t = np.concatenate([np.arange(a, b) for a, b in zip(starts, ends)])
        first = np.repeat(starts, lengths)
        last = np.repeat(ends - 1, lengths)
        base = t - (n_obs_steps - 1)
        self.obs_index = torch.from_numpy(np.clip(base[:, None] + np.arange(n_obs_steps), first[:, None], last[:, None]))
        self.action_index = torch.from_numpy(np.clip(base[:, None] + np.arange(horizon), first[:, None], last[:, None]))
        self.episode = torch.from_numpy(np.repeat(np.arange(dataset.num_episodes), lengths))
        self.progress = torch.from_numpy((t - first) / np.repeat(lengths, lengths))  # 0 at an episode's start
        self.served = torch.arange(len(t))  # the windows ``get`` indexes into (see keep_early)
        self.state = torch.from_numpy(dataset.state.astype(np.float32))
        self.action = torch.from_numpy(dataset.action.astype(np.float32))
        self.goal = torch.from_numpy(dataset.goal.astype(np.float32))
        self.goals = torch.from_numpy(dataset.goals.astype(np.float32))
        self.target = torch.from_numpy(np.repeat(dataset.target_index, lengths))
        # task-space point of every state (TCP by forward kinematics for the Panda)
        points = task.task_space(dataset.state.astype(np.float64))
        self.position = torch.from_numpy(np.asarray(points, dtype=np.float32))

    def __len__(self) -> int:
        return len(self.served)

    def to(self, device) -> WindowData:
        """Every tensor on ``device`` (the training loop's, once: then a batch is indexed where it is used)."""
        for name, value in vars(self).items():
            if torch.is_tensor(value):
                setattr(self, name, value.to(device))
        return self

    def keep_early(self, fraction: float) -> WindowData:
        """Serve only the windows in the first ``fraction`` of each episode (where a path's side is decided)."""
        return self.keep(self.progress < fraction)

    def keep(self, mask) -> WindowData:
        """Serve only the windows where ``mask`` (N,) is true, of those still served."""
        mask = torch.as_tensor(mask, dtype=torch.bool, device=self.progress.device)
        served = torch.zeros_like(mask)
        served[self.served] = True
        self.served = torch.nonzero(mask & served).flatten()
        return self

    def get(self, idx: torch.Tensor) -> TrainBatch:
        idx = self.served[idx]
        t = self.obs_index[idx, -1]
        return TrainBatch(
            obs_state=self.state[self.obs_index[idx]],
            obs_position=self.position[self.obs_index[idx]],
            action=self.action[self.action_index[idx]],
            goal=self.goal[t],
            goals=self.goals[t],
            target=self.target[idx],
        )

    # what the normaliser is fitted on ------------------------------------------------------
    def current_states(self) -> torch.Tensor:
        """(N, S): the last observed state of every window."""
        return self.state[self.obs_index[:, -1]]

    def action_chunks(self, relative: bool) -> torch.Tensor:
        """(N, H, S): every window's action chunk, absolute or relative to its current state."""
        chunks = self.action[self.action_index]
        return chunks - self.current_states()[:, None] if relative else chunks

    def goal_offsets(self) -> torch.Tensor:
        """(N, G): g* - p(s) at every window's current state."""
        last = self.obs_index[:, -1]
        return self.goal[last] - self.position[last]


class SceneData:
    """Random scenes for the scene autoencoder, from the encoder's own stream
    (:func:`scdp.data.scenes.sample_scenes`); ``get(idx) -> SceneBatch``."""

    def __init__(self, task: Task, n_scenes: int, n_goals: int, seed: int):
        scenes = sample_scenes(task, n_scenes, seed, n_goals, stream=ENCODER)
        self.goals = torch.from_numpy(np.stack([g for g, _ in scenes]).astype(np.float32))
        self.target = torch.from_numpy(np.array([t for _, t in scenes]))

    def __len__(self) -> int:
        return len(self.goals)

    def to(self, device) -> SceneData:
        """Every scene on ``device``."""
        self.goals, self.target = self.goals.to(device), self.target.to(device)
        return self

    def get(self, idx: torch.Tensor) -> SceneBatch:
        return SceneBatch(self.goals[idx], self.target[idx])
