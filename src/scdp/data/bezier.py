"""Quadratic Bézier paths sampled at a constant spacing along their length.

``B(t) = (1-t)^2 p0 + 2 t (1-t) p1 + t^2 p2`` for ``t`` in [0, 1]. Points are ``(d,)``;
sampled paths are ``(K, d)``.
"""

from __future__ import annotations

import numpy as np

from scdp.tasks import Task


def bezier(p0, p1, p2, t) -> np.ndarray:
    """Evaluate the quadratic Bézier at parameters ``t`` of shape (K,). Returns (K, d)."""
    t = np.asarray(t, dtype=np.float64)[:, None]
    return (1 - t) ** 2 * p0 + 2 * t * (1 - t) * p1 + t**2 * p2


def sample_by_arc_length(p0, p1, p2, step: float, dense: int = 2000) -> np.ndarray:
    """Points along the curve spaced ``step`` apart in arc length, from ``p0`` to exactly ``p2``.

    The curve is evaluated on ``dense`` parameters, its cumulative length is inverted by
    linear interpolation, and the last point is the end point (its gap is at most ``step``).
    """
    p0, p1, p2 = (np.asarray(p, dtype=np.float64) for p in (p0, p1, p2))
    t = np.linspace(0.0, 1.0, dense)
    pts = bezier(p0, p1, p2, t)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    n = max(int(np.ceil(s[-1] / step)), 1)
    targets = np.minimum(np.arange(n + 1) * step, s[-1])
    t_at = np.interp(targets, s, t)
    out = bezier(p0, p1, p2, t_at)
    out[-1] = p2
    return out


def sample_many_by_arc_length(p0, controls, p2, step: float, dense: int = 2000) -> list[np.ndarray]:
    """:func:`sample_by_arc_length` for many curves sharing their end points, ``controls`` (n, d): the
    dense evaluation and arc lengths of all n at once, each curve's result the same, value for value."""
    p0, p2 = np.asarray(p0, dtype=np.float64), np.asarray(p2, dtype=np.float64)
    controls = np.asarray(controls, dtype=np.float64)
    t = np.linspace(0.0, 1.0, dense)
    # bezier()'s expression term by term, laid out (n, d, dense) so every pass runs along the curve
    pts = (((1 - t) ** 2 * p0[:, None])[None] + (2 * t * (1 - t)) * controls[:, :, None]) + t**2 * p2[:, None]
    step_sq = np.diff(pts, axis=2) ** 2  # (n, d, dense - 1)
    lengths = np.sqrt(np.add.reduce(step_sq, axis=1))  # as np.linalg.norm sums the coordinates, in order
    s = np.concatenate([np.zeros((len(controls), 1)), np.cumsum(lengths, axis=1)], axis=1)
    out = []
    for control, arc in zip(controls, s):
        n = max(int(np.ceil(arc[-1] / step)), 1)
        targets = np.minimum(np.arange(n + 1) * step, arc[-1])
        path = bezier(p0, control, p2, np.interp(targets, arc, t))
        path[-1] = p2
        out.append(path)
    return out


def signed_bend(path) -> float:
    """Largest distance of ``path`` from its chord, over the chord length.

    The sign says on which side of the chord the bend lies, judged in the xy plane
    (positive: to the left of the start-to-end direction). 0 is a straight line; a
    control point offset of ``c`` chord lengths gives a bend of about ``c / 2``.
    """
    path = np.asarray(path, dtype=np.float64)
    chord = path[-1] - path[0]
    length = np.linalg.norm(chord)
    if length < 1e-12:
        return 0.0
    u = chord / length
    rel = path - path[0]
    perp = rel - np.outer(rel @ u, u)
    dist = np.linalg.norm(perp, axis=1)
    k = int(np.argmax(dist))
    side = np.sign(u[0] * perp[k, 1] - u[1] * perp[k, 0]) or 1.0
    return float(side * dist[k] / length)


def demo_path(task: Task, rng: np.random.Generator, start, target) -> tuple[np.ndarray, np.ndarray]:
    """One demonstration-style path from ``start`` to ``target``: the task draws a control point
    (:meth:`scdp.tasks.Task.sample_control_point`), and the Bézier through it is sampled every
    ``task.step_size`` metres. Returns (path (K, d), control point (d,))."""
    control = task.sample_control_point(rng, start, target)
    return sample_by_arc_length(start, control, target, task.step_size), control


def demo_paths(task: Task, rng: np.random.Generator, start, target, n: int) -> list[np.ndarray]:
    """``n`` draws of :func:`demo_path`'s path from ``rng``, as n calls in a row would make them (the
    control points are drawn one after another; the curves are sampled together)."""
    controls = np.array([task.sample_control_point(rng, start, target) for _ in range(n)])
    return sample_many_by_arc_length(start, controls, target, task.step_size)
