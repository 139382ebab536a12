"""Observer-based measures of a path: how soon, and how often, an observer names the target.

Dragan's legibility (:func:`scdp.metrics.legibility`) folds the observer's belief over the whole
motion into one number. An HRI study asks two plainer questions of the same belief, and these
functions answer them from a stored path (nothing is re-run):

* **time to confidence**: the first fraction of the motion after which the observer's
  ``P(g* | path so far)`` stays at or above a threshold (0.8 by default) until the end.
  A path whose belief ends below the threshold *never* becomes confident: the function returns
  ``None``, and such runs are counted apart (a share), never averaged in as 1.0;
* **prediction accuracy at a fraction** of the motion: is the observer's arg-max the target there?
  A tie is not a correct prediction (at the start every goal is equally likely).

The belief is :func:`scdp.metrics.observer_posterior` (the path-length observer, scale-free
``beta``) along a path given as points equally spaced in time, so point ``t`` of ``T`` sits at the
fraction ``t / (T - 1)`` of the motion. Pass the path as :mod:`scdp.scoring` scores D and legibility:
cut at the success radius and resampled to 200 points. Definitions and examples: ``docs/observers.md``.
"""

from __future__ import annotations

import numpy as np

from scdp.metrics import DEFAULT_BETA, observer_posterior

CONFIDENCE = 0.8  # the observer is confident once P(g*) stays at or above this
FRACTIONS = (0.25, 0.5, 0.75)  # where prediction accuracy is reported


def posterior_along(traj, goals, target: int, beta: float = DEFAULT_BETA) -> np.ndarray:
    """The observer's belief along a path: (T, K), row t is ``P(g | path up to point t)``.

    The path starts at its first point; costs are scaled by the start-to-target distance, as in
    :func:`scdp.metrics.legibility`, so ``beta`` means the same on a 0.3 m reach and a 3 m drive.
    """
    traj = np.asarray(traj, dtype=np.float64)
    goals = np.asarray(goals, dtype=np.float64)
    scale = max(float(np.linalg.norm(goals[target] - traj[0])), 1e-9)
    return observer_posterior(traj, traj[0], goals, beta, scale)


def time_to_confidence(p_target, threshold: float = CONFIDENCE) -> float | None:
    """The first fraction of the motion from which ``p_target`` (T,) stays ``>= threshold`` to the
    end; ``None`` when the last value is below it (never confident)."""
    p = np.asarray(p_target, dtype=np.float64)
    if len(p) < 2:
        raise ValueError(f"a motion needs at least two points, got {len(p)}")
    below = np.flatnonzero(p < threshold)
    if below.size and below[-1] == len(p) - 1:
        return None
    first = 0 if below.size == 0 else int(below[-1]) + 1
    return first / (len(p) - 1)


def correct_at(posterior, target: int, fractions=FRACTIONS) -> list[bool]:
    """Whether the observer's arg-max is the target at each fraction of the motion (the nearest
    point to ``fraction * (T - 1)``); a tie with another goal is not correct."""
    posterior = np.asarray(posterior, dtype=np.float64)
    n = len(posterior)
    out = []
    for f in fractions:
        if not 0.0 <= f <= 1.0:
            raise ValueError(f"a fraction of the motion lies in [0, 1], got {f}")
        row = posterior[int(round(f * (n - 1)))]
        out.append(bool(row[target] > np.max(np.delete(row, target))))
    return out


def observer_measures(traj, goals, target: int, *, beta: float = DEFAULT_BETA, threshold: float = CONFIDENCE,
                      fractions=FRACTIONS) -> dict:
    """Every observer measure of one path: ``time_to_confidence`` (``None``: never), and
    ``correct_at_<percent>`` for each fraction."""
    posterior = posterior_along(traj, goals, target, beta)
    measures: dict = {"time_to_confidence": time_to_confidence(posterior[:, target], threshold)}
    for f, ok in zip(fractions, correct_at(posterior, target, fractions)):
        measures[f"correct_at_{round(100 * f)}"] = ok
    return measures
