"""Min-max scaling to [-1, 1]: the policies' pre- and post-processing.

State and action statistics come from the training windows (actions as the policy sees
them: absolute, or relative to the current state); goal statistics from the task's goal box, so any scene in the workspace maps into range. A dimension that never
varies (Block Reach goal height) gets a span of 2 around its value and maps to 0.
Statistics are stored in each checkpoint's ``config.json``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch


@dataclass(frozen=True)
class MinMax:
    low: tuple[float, ...]
    high: tuple[float, ...]

    @classmethod
    def fit(cls, low, high) -> "MinMax":
        low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
        flat = (high - low) < 1e-6
        low, high = np.where(flat, low - 1.0, low), np.where(flat, high + 1.0, high)
        return cls(tuple(low.tolist()), tuple(high.tolist()))

    @classmethod
    def of(cls, data) -> "MinMax":
        data = np.asarray(data, dtype=np.float64)
        return cls.fit(data.min(axis=0), data.max(axis=0))

    def _t(self, like: torch.Tensor):
        low = torch.as_tensor(self.low, dtype=like.dtype, device=like.device)
        high = torch.as_tensor(self.high, dtype=like.dtype, device=like.device)
        return low, high

    def normalize(self, x: torch.Tensor) -> torch.Tensor:
        low, high = self._t(x)
        return 2.0 * (x - low) / (high - low) - 1.0

    def unnormalize(self, x: torch.Tensor) -> torch.Tensor:
        low, high = self._t(x)
        return (x + 1.0) / 2.0 * (high - low) + low


@dataclass(frozen=True)
class Normalizer:
    state: MinMax
    action: MinMax
    goal: MinMax
    offset: MinMax  # g* - p(s): the target seen from the robot

    @classmethod
    def from_windows(cls, windows, task, relative_actions: bool) -> "Normalizer":
        """Fit to a :class:`~scdp.training.windows.WindowData`'s states and action chunks."""
        chunks = windows.action[windows.action_index]  # (N, H, S)
        if relative_actions:
            chunks = chunks - windows.state[windows.obs_index[:, -1]][:, None]
        actions = chunks.reshape(-1, chunks.shape[-1]).numpy()
        offsets = (windows.goal[windows.obs_index[:, -1]] - windows.position[windows.obs_index[:, -1]]).numpy()
        return cls(MinMax.of(windows.state.numpy()), MinMax.of(actions), MinMax.fit(task.goal_low, task.goal_high),
                   MinMax.of(offsets))

    def to_dict(self) -> dict:
        return {k: {"low": list(getattr(self, k).low), "high": list(getattr(self, k).high)} for k in ("state", "action", "goal", "offset")}

    @classmethod
    def from_dict(cls, d: dict) -> "Normalizer":
        return cls(**{k: MinMax(tuple(d[k]["low"]), tuple(d[k]["high"])) for k in ("state", "action", "goal", "offset")})
