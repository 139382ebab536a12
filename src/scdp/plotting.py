"""Matplotlib figures: scenes, demonstration paths and the ellipse of ambiguity.

Everything draws onto Agg figures, so it works headless. Task-space paths are drawn
top-down (x, y); Block Reach figures add a side view (x, z).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Ellipse, Rectangle  # noqa: E402

from scdp.io import atomic_path  # noqa: E402

TARGET_COLOR = "tab:green"
NEGATIVE_COLOR = "tab:red"


def draw_scene(ax, task, goals, target, *, label: bool = True) -> None:
    """Goals (target green, distractors red), start and sampling box on a top-down axis."""
    lo, hi = task.goal_low, task.goal_high
    ax.add_patch(Rectangle(lo[:2], *(hi[:2] - lo[:2]), fill=False, ls=":", ec="0.6"))
    s = task.start_point
    ax.plot(s[0], s[1], "k^", ms=8, label="start" if label else None)
    goals = np.asarray(goals)
    for k, g in enumerate(goals):
        is_t = k == target
        ax.plot(g[0], g[1], "s" if task.space_dim == 3 else "o", ms=9,
                color=TARGET_COLOR if is_t else NEGATIVE_COLOR,
                label=("g*" if is_t else "g-") if label and k <= 1 else None)
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal")


def save_figure(fig: Figure, out) -> None:
    """Save atomically; the format follows the suffix (.png, .pdf, ...)."""
    from pathlib import Path

    out = Path(out)
    with atomic_path(out) as tmp:
        fig.savefig(tmp, format=out.suffix.lstrip(".") or "png", bbox_inches="tight")


def plot_demos(dataset, task, max_demos: int = 50) -> Figure:
    """Paths of the first ``max_demos`` demos over their scenes, coloured by how much they bend."""
    from scdp.data.bezier import signed_bend

    views = 2 if task.space_dim == 3 else 1
    fig = Figure(figsize=(6.5 * views, 5.5), dpi=120)
    axes = [fig.add_subplot(1, views, k + 1) for k in range(views)]
    cmap = matplotlib.colormaps["coolwarm"]
    n = min(max_demos, dataset.num_episodes)
    for i in range(n):
        ep = dataset.episode(i)
        path = task.episode_path(ep)
        bend = signed_bend(path)
        color = cmap(0.5 + np.clip(bend, -0.5, 0.5))
        axes[0].plot(path[:, 0], path[:, 1], color=color, lw=0.9, alpha=0.85)
        g = ep["goals"]
        t = ep["target"]
        axes[0].plot(g[t, 0], g[t, 1], "o", color=color, ms=4)
        neg = np.delete(g, t, axis=0)
        axes[0].plot(neg[:, 0], neg[:, 1], "x", color="0.4", ms=4)
        if views == 2:
            axes[1].plot(path[:, 0], path[:, 2], color=color, lw=0.9, alpha=0.85)
    s = task.start_point
    axes[0].plot(s[0], s[1], "k^", ms=9)
    lo, hi = task.goal_low, task.goal_high
    axes[0].add_patch(Rectangle(lo[:2], *(hi[:2] - lo[:2]), fill=False, ls=":", ec="0.5"))
    axes[0].set(xlabel="x [m]", ylabel="y [m]", aspect="equal",
                title=f"{task.name}: {n} demos (colour: signed bend; o target, x distractor)")
    if views == 2:
        axes[1].axhline(task.goal_low[2], color="0.5", ls=":")
        axes[1].plot(s[0], s[2], "k^", ms=9)
        axes[1].set(xlabel="x [m]", ylabel="z [m]", aspect="equal", title="side view")
    return fig


def plot_ellipse(task, goals, target, *, focus=None, settings=None) -> Figure:
    """The ellipse of ambiguity for one scene, in the style of the paper's Fig. 4b.

    For Block Reach the spheroid is projected onto the xy plane.
    """
    from scdp import ambiguity

    settings = settings or task.ambiguity
    goals = np.asarray(goals, dtype=np.float64)
    focus = task.start_point if focus is None else np.asarray(focus, dtype=np.float64)
    g_star = goals[target]
    negatives = np.delete(goals, target, axis=0)
    center, M = ambiguity.ellipse(focus, g_star, settings.kappa, settings.eccentricity)
    cov = np.linalg.inv(M)[:2, :2]  # projection of the ellipsoid onto xy
    w, V = np.linalg.eigh(np.linalg.inv(cov))
    angle = np.degrees(np.arctan2(V[1, 0], V[0, 0]))
    fig = Figure(figsize=(6, 5), dpi=120)
    ax = fig.add_subplot(1, 1, 1)
    ax.add_patch(Ellipse(center[:2], 2 / np.sqrt(w[0]), 2 / np.sqrt(w[1]), angle=angle,
                         fc="tab:orange", alpha=0.25, ec="tab:orange", lw=2, label="ellipse of ambiguity"))
    ax.plot(*np.vstack([focus, g_star])[:, :2].T, "k--", lw=1, label="straight path")
    ax.plot(center[0], center[1], "+", color="tab:orange", ms=12, mew=2, label=f"centre e (kappa={settings.kappa:g})")
    ax.plot(focus[0], focus[1], "k^", ms=9, label="s_t (focus)")
    ax.plot(g_star[0], g_star[1], "o", color=TARGET_COLOR, ms=10, label="g*")
    for k, g in enumerate(negatives):
        inside = ambiguity.in_ellipse(g, center, M)
        ax.plot(g[0], g[1], "o", color=NEGATIVE_COLOR, ms=10, label=f"g- ({'inside' if inside else 'outside'})" if k == 0 else None)
    verdict = ambiguity.is_ambiguous(focus, g_star, negatives, method="ellipse", settings=settings)
    ax.set(aspect="equal", xlabel="x [m]", ylabel="y [m]",
           title=f"{task.name}: {'ambiguous' if verdict else 'not ambiguous'} (eccentricity {settings.eccentricity:g})")
    ax.legend(loc="best", fontsize=8)
    ax.autoscale_view()
    return fig
