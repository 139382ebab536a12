"""Training windows cut from demonstrations, gathered in batches by index arithmetic.

For every step ``t`` of every episode there is one window: observations at
``t - O + 1 .. t`` and actions at ``t - O + 1 .. t - O + H`` (O = n_obs_steps,
H = horizon), clamped to the episode, so the first state is repeated before the start and
the final action (holding the goal) after the end — Diffusion Policy's padding. All index
tables are built once; ``get`` is a single gather per array.
"""

from __future__ import annotations

import numpy as np
import torch


class WindowData:
    def __init__(self, dataset, n_obs_steps: int, horizon: int, task=None):
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
        self.state = torch.from_numpy(dataset.state.astype(np.float32))
        self.action = torch.from_numpy(dataset.action.astype(np.float32))
        self.goal = torch.from_numpy(dataset.goal.astype(np.float32))
        self.goals = torch.from_numpy(dataset.goals.astype(np.float32))
        self.target = torch.from_numpy(np.repeat(dataset.target_index, lengths))
        # task-space point of every state (TCP by forward kinematics for the Panda)
        points = task.task_space(dataset.state.astype(np.float64)) if task is not None else dataset.goal * 0
        self.position = torch.from_numpy(np.asarray(points, dtype=np.float32))

    def __len__(self) -> int:
        return len(self.obs_index)

    def get(self, idx: torch.Tensor) -> dict:
        """Batch of windows: obs_state (B,O,S), obs_position (B,O,G), action (B,H,S), goal (B,G),
        goals (B,K,G), target (B,)."""
        t = self.obs_index[idx, -1]
        return {
            "obs_state": self.state[self.obs_index[idx]],
            "obs_position": self.position[self.obs_index[idx]],
            "action": self.action[self.action_index[idx]],
            "goal": self.goal[t],
            "goals": self.goals[t],
            "target": self.target[idx],
        }


class SceneData:
    """Random scenes for the scene autoencoder: goals (N, K, G) and targets (N,)."""

    def __init__(self, task, n_scenes: int, n_goals: int, seed: int):
        rng = np.random.default_rng(seed)
        scenes = [(task.sample_goals(rng, n_goals), int(rng.integers(n_goals))) for _ in range(n_scenes)]
        self.goals = torch.from_numpy(np.stack([g for g, _ in scenes]).astype(np.float32))
        self.target = torch.from_numpy(np.array([t for _, t in scenes]))

    def __len__(self) -> int:
        return len(self.goals)

    def get(self, idx: torch.Tensor) -> dict:
        return {"goals": self.goals[idx], "target": self.target[idx]}
