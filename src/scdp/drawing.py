"""Drawing a scene on a matplotlib axis: goals, start and the goal sampling box.

A leaf module (matplotlib only), used by the environments' ``render`` and by the figures.
The scene's frame is a :class:`SceneFrame`: any object with ``goal_low``, ``goal_high``,
``start_point`` and ``space_dim``, as every :class:`scdp.tasks.Task` has (a leaf cannot import
the tasks layer, so the annotation is this protocol).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

from typing import Protocol  # noqa: E402

import numpy as np  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

TARGET_COLOR = "tab:green"
NEGATIVE_COLOR = "tab:red"


class SceneFrame(Protocol):
    """What :func:`draw_scene` reads from a task."""

    goal_low: np.ndarray  # the goal sampling box, task space
    goal_high: np.ndarray
    space_dim: int  # 2: a ground robot's goals; 3: blocks on a table

    @property
    def start_point(self) -> np.ndarray: ...


def draw_scene(ax, task: SceneFrame, goals, target, *, label: bool = True) -> None:
    """Goals (target green, distractors red), start and sampling box on a top-down axis."""
    lo, hi = task.goal_low, task.goal_high
    ax.add_patch(Rectangle(lo[:2], *(hi[:2] - lo[:2]), fill=False, ls=":", ec="0.6"))
    s = task.start_point
    ax.plot(s[0], s[1], "k^", ms=8, label="start" if label else None)
    for k, g in enumerate(goals):
        is_target = k == target
        ax.plot(g[0], g[1], "s" if task.space_dim == 3 else "o", ms=9,
                color=TARGET_COLOR if is_target else NEGATIVE_COLOR,
                label=("g*" if is_target else "g-") if label and k <= 1 else None)
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal")
