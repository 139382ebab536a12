"""Drawing a scene on a matplotlib axis: goals, start and the goal sampling box.

A leaf module (matplotlib only), used by the environments' ``render`` and by the figures.
``task`` is anything with ``goal_low``, ``goal_high``, ``start_point`` and ``space_dim``.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

from matplotlib.patches import Rectangle  # noqa: E402

TARGET_COLOR = "tab:green"
NEGATIVE_COLOR = "tab:red"


def draw_scene(ax, task, goals, target, *, label: bool = True) -> None:
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
