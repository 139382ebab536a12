"""Matplotlib figures: demonstrations, the ellipse of ambiguity and the paper's Figure 2.

Everything draws onto Agg figures, so it works headless. Task-space paths are drawn
top-down (x, y); Block Reach's demo figure adds a side view (x, z).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Ellipse, Rectangle

from scdp import ambiguity
from scdp.data.bezier import signed_bend
from scdp.drawing import NEGATIVE_COLOR, TARGET_COLOR
from scdp.evaluation.tables import METHOD_NAMES, SETS, ordered_tasks, task_title
from scdp.io import atomic_path
from scdp.keys import layout_number
from scdp.tasks import Task, get_task

IMAGE_FORMATS = ("png", "pdf", "svg", "jpg", "jpeg")


def save_figure(fig: Figure, out) -> None:
    """Save atomically; the format follows the suffix (.png, .pdf, .svg, .jpg). No creation date is
    written, so the same figure gives the same bytes on every run."""
    out = Path(out)
    fmt = out.suffix.lstrip(".").lower() or "png"
    metadata = {"pdf": {"CreationDate": None}, "svg": {"Date": None}}.get(fmt)
    with atomic_path(out) as tmp:
        fig.savefig(tmp, format=fmt, bbox_inches="tight", metadata=metadata)


def plot_demos(dataset, task: Task, max_demos: int = 50) -> Figure:
    """Paths of the first ``max_demos`` demos over their scenes, coloured by how much they bend."""
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


def plot_ellipse(task: Task, goals, target, *, focus=None, settings=None) -> Figure:
    """The ellipse of ambiguity for one scene, in the style of the paper's Fig. 4b.

    For Block Reach the spheroid is projected onto the xy plane.
    """
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
    inside = ambiguity.ellipse_inside(focus[None], goals[None], np.array([target]), settings.kappa, settings.eccentricity)[0]
    for k, g in enumerate(goals):
        if k != target:
            first = k == (1 if target == 0 else 0)
            ax.plot(g[0], g[1], "o", color=NEGATIVE_COLOR, ms=10, label=f"g- ({'inside' if inside[k] else 'outside'})" if first else None)
    verdict = ambiguity.is_ambiguous(focus, g_star, negatives, method="ellipse", settings=settings)
    ax.set(aspect="equal", xlabel="x [m]", ylabel="y [m]",
           title=f"{task.name}: {'ambiguous' if verdict else 'not ambiguous'} (eccentricity {settings.eccentricity:g})")
    ax.legend(loc="best", fontsize=8)
    ax.autoscale_view()
    return fig


FIGURE_METHODS = {"dp": "tab:blue", "ld": "tab:purple", "scdp": "tab:orange", "scdp_legible": "tab:red", "dataset": "0.4"}
FIGURE_TITLES = {**METHOD_NAMES, "scdp_legible": "SCDP, forced legible"}


def scene_limits(task: Task, goals, margin: float = 0.35) -> tuple[tuple[float, float], tuple[float, float]]:
    """Top-down axis limits framing the start and the goals, the same for every method of a row."""
    points = np.vstack([task.start_point[None, :2], np.asarray(goals)[:, :2]])
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = margin * max(float((hi - lo).max()), 1e-3)
    centre, half = (lo + hi) / 2, (hi - lo).max() / 2 + pad
    return (centre[0] - half, centre[0] + half), (centre[1] - half, centre[1] + half)


def figure2(records: list, figure_scenes: dict):
    """Each method's trajectories in one ambiguous and one non-ambiguous scene per task.

    ``figure_scenes[task][label]`` is the scene set name to draw: for a layout (``layout_1``)
    every record of the set with target 0 (its repeats), for a random set (``ambiguous``) its
    first scene. The methods of a row share its axes, framed on
    the scene (a path that wanders off is clipped, not allowed to rescale its panel). The
    forced-legible SCDP column appears when those records exist.
    """
    tasks = ordered_tasks(figure_scenes)
    rows = [(t, label) for t in tasks for label in ("ambiguous", "not ambiguous")]
    methods = [m for m in FIGURE_METHODS if m != "scdp_legible" or any(r.method == m for r in records)]
    fig = Figure(figsize=(3.2 * len(methods), 3.0 * len(rows)), dpi=110)
    for i, (task, label) in enumerate(rows):
        name = figure_scenes[task][label]
        task_obj = get_task(task)
        row = [r for r in records if r.task == task and r.scene_set == name
               and (r.target == 0 if layout_number(name) is not None else r.scene_index == 0)]
        limits = scene_limits(task_obj, row[0].goals) if row else None
        for j, m in enumerate(methods):
            ax = fig.add_subplot(len(rows), len(methods), i * len(methods) + j + 1)
            rs = [r for r in row if r.method == m]
            for r in rs:
                p = np.asarray(r.path)
                ax.plot(p[:, 0], p[:, 1], color=FIGURE_METHODS[m], lw=1.0, alpha=0.6)
            if rs:
                g, t = np.asarray(rs[0].goals), rs[0].target
                ax.plot(g[t, 0], g[t, 1], "o", color=TARGET_COLOR, ms=8)
                neg = np.delete(g, t, axis=0)
                ax.plot(neg[:, 0], neg[:, 1], "o", color=NEGATIVE_COLOR, ms=8)
            s = task_obj.start_point
            ax.plot(s[0], s[1], "k^", ms=6)
            if limits:
                ax.set(xlim=limits[0], ylim=limits[1])
            ax.set_aspect("equal", adjustable="box")
            ax.tick_params(labelsize=6)
            if i == 0:
                ax.set_title(FIGURE_TITLES[m], fontsize=9)
            if j == 0:
                ax.set_ylabel(f"{task_title(task)}\n{label} ({name})", fontsize=8)
    fig.tight_layout()
    return fig


def observer_accuracy(summary: dict) -> Figure:
    """The observer's accuracy over the motion, one line per method, one panel per task and random
    scene set (``summary``: :func:`scdp.evaluation.observation.observer_summary`)."""
    tasks = ordered_tasks(summary["tasks"])
    sets = [s for s in SETS if any(s in summary["tasks"][t] for t in tasks)]
    fig = Figure(figsize=(5.2 * len(sets), 3.8 * len(tasks)), dpi=120)
    x = np.asarray(summary["curve_fractions"])
    for i, task in enumerate(tasks):
        for j, scene_set in enumerate(sets):
            ax = fig.add_subplot(len(tasks), len(sets), i * len(sets) + j + 1)
            for method, m in summary["tasks"][task].get(scene_set, {}).items():
                ax.plot(x, m["curve"], label=FIGURE_TITLES.get(method, method), lw=1.6)
            ax.set(title=f"{task_title(task)}, {scene_set.replace('_', '-')} scenes", xlim=(0, 1), ylim=(-0.02, 1.02),
                   xlabel="fraction of the motion", ylabel="observer predicts g* (share of runs)")
            ax.grid(alpha=0.3)
    beta = ", ".join(f"{b:g}" for b in summary["beta"])
    fig.suptitle(f"{summary['observer']}, β = {beta}")
    fig.axes[0].legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    return fig
