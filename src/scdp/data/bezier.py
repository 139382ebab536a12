"""Quadratic Bézier paths sampled at a constant spacing along their length, and paths that turn.

``B(t) = (1-t)^2 p0 + 2 t (1-t) p1 + t^2 p2`` for ``t`` in [0, 1]. Points are ``(d,)``;
sampled paths are ``(K, d)``.

A quadratic Bézier never changes the side it bends to, so a path of them that heads straight for
its goal keeps heading straight: no demonstration shows a motion under way that turns to another
style. :func:`turning_path` makes one: one demo curve followed up to a drawn point, then blended
smoothly into another to the same goal.
"""

from __future__ import annotations

import numpy as np

from scdp.tasks import Task


def bezier(p0, p1, p2, t) -> np.ndarray:
    """Evaluate the quadratic Bézier at parameters ``t`` of shape (K,). Returns (K, d)."""
    t = np.asarray(t, dtype=np.float64)[:, None]
    return (1 - t) ** 2 * p0 + 2 * t * (1 - t) * p1 + t**2 * p2


DENSE = 2000  # parameters a curve is evaluated on before its arc length is inverted


def _arc_lengths(curve, dense: int) -> tuple[np.ndarray, np.ndarray]:
    """(parameters (dense,), cumulative arc length at each) of ``curve`` evaluated densely."""
    t = np.linspace(0.0, 1.0, dense)
    pts = curve(t)
    return t, np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])


def parameter_at_length(curve, length: float, dense: int = DENSE) -> float:
    """The parameter at which ``curve`` (parameters (K,) -> points (K, d)) has run ``length`` along itself."""
    t, s = _arc_lengths(curve, dense)
    return float(np.interp(length, s, t))


def curve_by_arc_length(curve, end, step: float, dense: int = DENSE) -> np.ndarray:
    """``curve(t)`` (a function of parameters (K,) -> points (K, d)) at points ``step`` apart in arc length, the
    last one exactly ``end``."""
    t, s = _arc_lengths(curve, dense)
    n = max(int(np.ceil(s[-1] / step)), 1)
    targets = np.minimum(np.arange(n + 1) * step, s[-1])
    out = curve(np.interp(targets, s, t))
    out[-1] = end
    return out


def sample_by_arc_length(p0, p1, p2, step: float, dense: int = DENSE) -> np.ndarray:
    """Points along the curve spaced ``step`` apart in arc length, from ``p0`` to exactly ``p2``.

    The curve is evaluated on ``dense`` parameters, its cumulative length is inverted by
    linear interpolation, and the last point is the end point (its gap is at most ``step``).
    """
    p0, p1, p2 = (np.asarray(p, dtype=np.float64) for p in (p0, p1, p2))
    return curve_by_arc_length(lambda t: bezier(p0, p1, p2, t), p2, step, dense)


def sample_many_by_arc_length(p0, controls, p2, step: float, dense: int = DENSE) -> list[np.ndarray]:
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


TURN_AT = (0.15, 0.6)  # where (curve parameter) a turning demo starts to turn, drawn uniformly
TURN_SPAN = 0.5  # ... and the parameter span over which it moves from one course to the other
TURN_SPAN_FROM_POINT = 0.3  # the same for a second course that starts at the turn (turning_path's from_point)


def smoothstep(x) -> np.ndarray:
    """0 below 0, 1 above 1, ``3x^2 - 2x^3`` between: a blend weight whose slope is 0 at both ends."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return x * x * (3 - 2 * x)


def turning_curve(start, first, target, at: float, second, from_point: bool = False):
    """The curve (a function of parameters (K,) -> points (K, d)) of a path that follows the Bézier through
    ``first`` up to parameter ``at``, then blends by :func:`smoothstep` into the Bézier through ``second``: from
    ``start`` over :data:`TURN_SPAN`, or (``from_point``) from the turn point itself over
    :data:`TURN_SPAN_FROM_POINT`, ``second`` then drawn for what is left of the way."""
    start, target = np.asarray(start, dtype=np.float64), np.asarray(target, dtype=np.float64)
    if from_point:
        turn, span = bezier(start, first, target, [at])[0], TURN_SPAN_FROM_POINT

        def course(t):  # the turn point until the turn, then the fresh curve from it
            return bezier(turn, second, target, np.clip((t - at) / (1 - at), 0.0, 1.0))
    else:
        span = TURN_SPAN

        def course(t):
            return bezier(start, second, target, t)

    def curve(t):
        t = np.asarray(t, dtype=np.float64)
        w = smoothstep((t - at) / span)[:, None]
        return (1 - w) * bezier(start, first, target, t) + w * course(t)
    return curve


def turning_path(task: Task, rng: np.random.Generator, start, target, *,
                 from_point: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """A demo path that changes its course part-way: two demo curves to the same target (two draws of
    :meth:`~scdp.tasks.Task.sample_control_point`), the first followed up to a parameter drawn in
    :data:`TURN_AT`, then blended smoothly into the second (:func:`turning_curve`, no kink), the second followed
    to the end. A straight start may so bend away, and a bent one straighten. With ``from_point`` the second
    curve starts where the turn does (its control point drawn for what is left of the way, so a late turn bends
    as much for the rest as an early one). Returns (path (K, d) sampled every ``task.step_size``, the first
    curve's control point (d,))."""
    start, target = np.asarray(start, dtype=np.float64), np.asarray(target, dtype=np.float64)
    first = task.sample_control_point(rng, start, target)
    if from_point:  # the draws in this order (first, turn, second) and, below, (first, second, turn): seeds stay demos
        at = rng.uniform(*TURN_AT)
        second = task.sample_control_point(rng, bezier(start, first, target, [at])[0], target)
    else:
        second = task.sample_control_point(rng, start, target)
        at = rng.uniform(*TURN_AT)
    return curve_by_arc_length(turning_curve(start, first, target, at, second, from_point), target, task.step_size,
                          DENSE), first
