"""Min-max scaling to [-1, 1]: the policies' pre- and post-processing, fitted in one place.

:func:`fit_normalizer` fits every statistic a policy needs from its training windows: states,
action chunks (as the policy sees them: absolute, or relative to the current state) and the
target offsets ``g* - p(s)``. Goals are scaled over the task's goal box
(:func:`goal_scaling`, also used by the scene encoder), so any scene in the workspace maps
into range. A dimension that never varies (Block Reach goal height) gets a span of 2 around
its value and maps to 0. The statistics are stored in each checkpoint's ``config.json``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from scdp.errors import ScdpError
from scdp.tasks import Task

MIN_SPAN = 1e-6  # a fitted range narrower than this is widened to 2 (a constant dimension), so no saved one is



@dataclass(frozen=True)
class MinMax:
    low: tuple[float, ...]
    high: tuple[float, ...]

    @classmethod
    def fit(cls, low, high) -> MinMax:
        low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
        flat = (high - low) < MIN_SPAN
        low, high = np.where(flat, low - 1.0, low), np.where(flat, high + 1.0, high)
        return cls(tuple(low.tolist()), tuple(high.tolist()))

    @classmethod
    def of(cls, data) -> MinMax:
        """Fitted to the range of ``data`` (N, D)."""
        data = np.asarray(data, dtype=np.float64)
        return cls.fit(data.min(axis=0), data.max(axis=0))

    def _bounds(self, like: torch.Tensor):
        low = torch.as_tensor(self.low, dtype=like.dtype, device=like.device)
        high = torch.as_tensor(self.high, dtype=like.dtype, device=like.device)
        return low, high

    def normalize(self, x: torch.Tensor) -> torch.Tensor:
        low, high = self._bounds(x)
        return 2.0 * (x - low) / (high - low) - 1.0

    def unnormalize(self, x: torch.Tensor) -> torch.Tensor:
        low, high = self._bounds(x)
        return (x + 1.0) / 2.0 * (high - low) + low


def goal_scaling(task: Task) -> MinMax:
    """Goals scaled over the task's goal sampling box (policies and scene encoder alike)."""
    return MinMax.fit(task.goal_low, task.goal_high)


@dataclass(frozen=True)
class Normalizer:
    state: MinMax
    action: MinMax
    goal: MinMax
    offset: MinMax  # g* - p(s): the target seen from the robot

    def to_dict(self) -> dict:
        return {k: {"low": list(getattr(self, k).low), "high": list(getattr(self, k).high)} for k in NORMALIZER_KEYS}

    @classmethod
    def from_dict(cls, d, dims: dict[str, int] | None = None) -> Normalizer:
        """Read saved statistics, refusing missing keys, non-numbers, ranges narrower than
        :data:`MIN_SPAN` (low == high would divide by zero when scaling) and (with ``dims``, e.g.
        ``{"state": 3, "goal": 2}``) vectors of the wrong length."""
        if not isinstance(d, dict):
            raise ScdpError("normalizer", f"expected an object of {', '.join(NORMALIZER_KEYS)}, got {type(d).__name__}")
        out = {}
        for k in NORMALIZER_KEYS:
            try:
                low = np.asarray(d[k]["low"], dtype=np.float64)
                high = np.asarray(d[k]["high"], dtype=np.float64)
            except (KeyError, TypeError, ValueError):
                raise ScdpError(f"normalizer/{k}", "needs numeric 'low' and 'high' vectors") from None
            want = (dims or {}).get(k)
            if low.ndim != 1 or low.shape != high.shape or (want is not None and len(low) != want):
                raise ScdpError(f"normalizer/{k}", f"low/high of lengths {low.shape}/{high.shape}, expected {want or 'equal'}")
            if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
                raise ScdpError(f"normalizer/{k}", "needs finite bounds")
            narrow = np.flatnonzero(~(high - low >= MIN_SPAN))
            if len(narrow):
                j = int(narrow[0])
                raise ScdpError(f"normalizer/{k}", f"dimension {j} has low {low[j]:.6g} and high {high[j]:.6g}; high "
                                                   f"must exceed low by at least {MIN_SPAN:g} (a constant dimension is "
                                                   "saved widened)")
            out[k] = MinMax(tuple(low.tolist()), tuple(high.tolist()))
        return cls(**out)

    @classmethod
    def placeholder(cls, task: Task) -> Normalizer:
        """Unit state/action ranges, for building an untrained policy (dry runs, timing)."""
        unit = MinMax.fit([-1.0] * task.state_dim, [1.0] * task.state_dim)
        return cls(unit, unit, goal_scaling(task), goal_scaling(task))


NORMALIZER_KEYS = ("state", "action", "goal", "offset")


def fit_normalizer(windows, task: Task, relative_actions: bool) -> Normalizer:
    """Fit to a :class:`~scdp.data.windows.WindowData`'s states, action chunks and target offsets."""
    chunks = windows.action_chunks(relative_actions)
    actions = chunks.reshape(-1, chunks.shape[-1]).numpy()
    return Normalizer(MinMax.of(windows.state.numpy()), MinMax.of(actions), goal_scaling(task),
                      MinMax.of(windows.goal_offsets().numpy()))
