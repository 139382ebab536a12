"""Spatial ambiguity: the paper's probabilistic definition (eq. 3) and its ellipse proxy.

A leaf module (numpy and :mod:`scdp.metrics` only). Both tests work in task space on the
robot's current point ``s`` (the start, or the state at a replanning step), the target
``g*`` and one or more distractors ``g-``. The per-task calibrated settings live in
``task.ambiguity``; :mod:`scdp.evaluation.calibration` re-derives them.

**Probabilistic (eq. 3).** Along the straight path ``xi*`` from ``s`` to ``g*``, Dragan's
observer (:func:`scdp.metrics.observer_posterior`) gives ``P(g* | xi*_{s->t})`` and
``P(g- | xi*_{s->t})``. At ``t = 0`` both equal 1/K for every scene, so the test cannot be
taken pointwise. We aggregate it over the path with Dragan's weights ``f(t) = T - t``:

    margin = sum_t f(t) [P(g* | .) - max_{g-} P(g- | .)] / sum_t f(t)

and call the scene ambiguous when ``margin < tau``. The path has 200 points.

**Ellipse (the run-time proxy).** The ellipse (a prolate spheroid in 3-D) has ``s`` as a
focus and its centre at ``e = s + kappa (g* - s)``, so the focal distance is
``c = kappa ||g* - s||``. Its shape is set by the eccentricity ``ecc``: semi-major axis
``a = c / ecc`` along ``g* - s`` and semi-minor axes ``b = a sqrt(1 - ecc^2)``. Hence

    M = I / b^2 + (1 / a^2 - 1 / b^2) u u^T,   u = (g* - s) / ||g* - s||

and the scene is ambiguous when some ``(g- - e)^T M (g- - e) <= 1``. It scales with the
remaining distance, so it shrinks as the robot closes in on its target.

Shapes: B scenes, K goals, d task-space dimensions.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from scdp.errors import ScdpError, finite_array
from scdp.metrics import observer_posterior, time_weights

PATH_POINTS = 200


@dataclass(frozen=True)
class AmbiguitySettings:
    """Calibrated parameters of both definitions.

    ``beta``: observer temperature per unit of start-to-target distance (> 0).
    ``tau``: a scene is ambiguous when the f(t)-weighted mean of P(g*) - max P(g-) along the
    straight path is below ``tau``. ``kappa`` in (0.5, 1): centre of the ellipse at
    ``s + kappa (g* - s)``. ``eccentricity`` in (0, 1): of the ellipse, whose focus is ``s``.
    """

    beta: float
    tau: float
    kappa: float
    eccentricity: float

    def __post_init__(self):
        for name in ("beta", "tau", "kappa", "eccentricity"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
                raise ScdpError(name, f"must be a finite number, got {value!r}")
        if not self.beta > 0:
            raise ScdpError("beta", f"must be > 0, got {self.beta}")
        if not 0.5 < self.kappa < 1.0:
            raise ScdpError("kappa", f"must lie in (0.5, 1), got {self.kappa}")
        if not 0.0 < self.eccentricity < 1.0:
            raise ScdpError("eccentricity", f"must lie in (0, 1), got {self.eccentricity}")


def straight_margins(starts, goals, targets, beta: float, n: int = PATH_POINTS) -> np.ndarray:
    """Eq. 3's margin for B scenes: starts (B, d), goals (B, K, d), targets (B,) -> (B,)."""
    starts = np.asarray(starts, dtype=np.float64)
    goals = np.asarray(goals, dtype=np.float64)
    B, K, _ = goals.shape
    rows = np.arange(B)
    g_star = goals[rows, targets]
    scale = np.maximum(np.linalg.norm(g_star - starts, axis=-1), 1e-9)  # (B,)
    s = np.linspace(0.0, 1.0, n)
    points = starts[:, None] + s[None, :, None] * (g_star - starts)[:, None]  # (B, n, d)
    p = observer_posterior(points, starts, goals, beta, scale)  # (B, n, K)
    p_star = p[rows, :, targets]  # (B, n)
    others = np.ones((B, K), dtype=bool)
    others[rows, targets] = False
    p_neg = np.where(others[:, None, :], p, -np.inf).max(axis=-1)
    f = time_weights(n)
    return ((p_star - p_neg) * f).sum(axis=1) / f.sum()


def ellipse(focus, target, kappa: float, eccentricity: float) -> tuple[np.ndarray, np.ndarray]:
    """Centre ``e`` (d,) and matrix ``M`` (d, d) of the ellipse, for drawing it."""
    focus = np.asarray(focus, dtype=np.float64)
    axis = np.asarray(target, dtype=np.float64) - focus
    dist = max(float(np.linalg.norm(axis)), 1e-9)
    u = axis / dist
    a = kappa * dist / eccentricity
    b = a * np.sqrt(1.0 - eccentricity**2)
    M = np.eye(len(focus)) / b**2 + (1.0 / a**2 - 1.0 / b**2) * np.outer(u, u)
    return focus + kappa * axis, M


def ellipse_forms(starts, goals, targets, kappa: float, eccentricity: float) -> np.ndarray:
    """``q = (g - e)^T M (g - e)`` for every goal of B scenes: (B, K), the target's q = inf.

    Evaluated as the sum of the squared along-axis and across-axis coordinates over a^2 and
    b^2 (see the module docstring). A goal is inside the ellipse when q <= 1.
    """
    starts = np.asarray(starts, dtype=np.float64)
    goals = np.asarray(goals, dtype=np.float64)
    B = len(goals)
    g_star = goals[np.arange(B), targets]
    axis = g_star - starts
    dist = np.maximum(np.linalg.norm(axis, axis=-1), 1e-9)
    u = axis / dist[:, None]
    a = kappa * dist / eccentricity
    b2 = (a * np.sqrt(1 - eccentricity**2)) ** 2
    r = goals - (starts + kappa * axis)[:, None]  # (B, K, d)
    along = np.einsum("bkd,bd->bk", r, u)
    q = (np.einsum("bkd,bkd->bk", r, r) - along**2) / b2[:, None] + along**2 / (a**2)[:, None]
    q[np.arange(B), targets] = np.inf
    return q


def ellipse_inside(starts, goals, targets, kappa: float, eccentricity: float) -> np.ndarray:
    """Which goals lie inside each scene's ellipse: (B, K) booleans, the target always False."""
    return ellipse_forms(starts, goals, targets, kappa, eccentricity) <= 1.0


def legible_weight(starts, goals, targets, settings: AmbiguitySettings, sharpness: float = 4.0) -> np.ndarray:
    """A smooth version of the ellipse test, in [0, 1]: ``sigmoid(sharpness (1 - q_min))``.

    ``q_min`` is the nearest distractor's :func:`ellipse_forms` value (1 on the ellipse's
    boundary, where the hard test switches). The weight is 0.5 there, tends to
    ``sigmoid(sharpness)`` at the ellipse's centre and to 0 far outside.
    """
    q = ellipse_forms(starts, goals, targets, settings.kappa, settings.eccentricity).min(axis=1)
    z = sharpness * (1.0 - q)
    e = np.exp(-np.abs(z))  # the logistic sigmoid of z, without overflow and keeping both tails above 0
    return np.where(z >= 0, 1.0 / (1.0 + e), e / (1.0 + e))


def ellipse_flags(starts, goals, targets, settings: AmbiguitySettings) -> np.ndarray:
    """The ellipse test for B scenes: (B,) True where a distractor lies inside."""
    return ellipse_inside(starts, goals, targets, settings.kappa, settings.eccentricity).any(axis=1)


def probabilistic_flags(starts, goals, targets, settings: AmbiguitySettings) -> np.ndarray:
    """Eq. 3 for B scenes: (B,) True where the margin is below ``tau``."""
    return straight_margins(starts, goals, targets, settings.beta) < settings.tau


def is_ambiguous(state_point, target, negatives, *, settings: AmbiguitySettings, method: str = "ellipse",
                 **overrides) -> bool:
    """Is one scene ambiguous seen from ``state_point`` (a task-space point)? Validates its input.

    ``method="ellipse"`` uses the run-time proxy, ``method="probabilistic"`` eq. 3. Keyword
    ``overrides`` (``beta``, ``tau``, ``kappa``, ``eccentricity``) replace fields of ``settings``.
    """
    s = finite_array(state_point, "state")
    g = finite_array(target, "target", s.shape)
    neg = np.atleast_2d(finite_array(negatives, "negatives"))
    if neg.shape[1] != s.shape[0]:
        raise ScdpError("negatives", f"expected points of dimension {s.shape[0]}, got {neg.shape[1]}")
    settings = replace(settings, **overrides)
    tests = {"ellipse": ellipse_flags, "probabilistic": probabilistic_flags}
    if method not in tests:
        raise ScdpError("method", f"unknown ambiguity method {method!r} (ellipse or probabilistic)")
    return bool(tests[method](s[None], np.vstack([g, neg])[None], np.array([0]), settings)[0])
