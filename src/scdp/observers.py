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

Two observers are declared. :func:`posterior_along` is Dragan & Srinivasa's path-length observer
(:func:`scdp.metrics.observer_posterior`, scale-free ``beta``): it expects the shortest path to
each goal. :func:`demonstration_posterior` expects the demonstrations' own motion: a goal is likely
when one of its demonstration-style paths passes where the robot has been. Both read a path given
as points equally spaced in time, so point ``t`` of ``T`` sits at the fraction ``t / (T - 1)`` of
the motion. Pass the path as :mod:`scdp.scoring` scores D and legibility:
cut at the success radius and resampled to 200 points. Definitions and examples: ``docs/observers.md``.
"""

from __future__ import annotations

import numpy as np

from scdp.metrics import DEFAULT_BETA, observer_posterior

CONFIDENCE = 0.8  # the observer is confident once P(g*) stays at or above this
FRACTIONS = (0.25, 0.5, 0.75)  # where prediction accuracy is reported
DEMO_BETA = 20.0  # the demonstration observer's temperature, per start-to-target length (docs/observers.md)


def posterior_along(traj, goals, target: int, beta: float = DEFAULT_BETA) -> np.ndarray:
    """The observer's belief along a path: (T, K), row t is ``P(g | path up to point t)``.

    The path starts at its first point; costs are scaled by the start-to-target distance, as in
    :func:`scdp.metrics.legibility`, so ``beta`` means the same on a 0.3 m reach and a 3 m drive.
    """
    traj = np.asarray(traj, dtype=np.float64)
    goals = np.asarray(goals, dtype=np.float64)
    scale = max(float(np.linalg.norm(goals[target] - traj[0])), 1e-9)
    return observer_posterior(traj, traj[0], goals, beta, scale)


def demonstration_gaps(traj, families) -> np.ndarray:
    """δ of :func:`demonstration_posterior`: (T, K, M), the mean distance of the path's points so far
    from each of every goal's M demonstrations (``families`` (K, M, R, d)). Each demonstration is
    first moved to start where the path starts (a robot's start is noisy), the shift fading to
    zero at its goal, so the belief starts uniform."""
    traj = np.asarray(traj, dtype=np.float64)
    families = np.asarray(families, dtype=np.float64)
    K, M, R, d = families.shape
    fade = np.linspace(1.0, 0.0, R)[:, None]  # (R, 1)
    families = families + fade * (traj[0] - families[:, :, :1])  # (K, M, R, d)
    flat = families.reshape(-1, d)  # squared distances as |a|² + |b|² - 2 a·b: one matrix product
    sq = (traj**2).sum(axis=1)[:, None] + (flat**2).sum(axis=1)[None] - 2.0 * traj @ flat.T
    gap = np.sqrt(np.maximum(sq, 0.0)).reshape(len(traj), K, M, R).min(axis=-1)  # (T, K, M)
    return np.cumsum(gap, axis=0) / np.arange(1, len(traj) + 1)[:, None, None]


def demonstration_belief(gaps, scale: float, beta: float = DEMO_BETA) -> np.ndarray:
    """(T, K) from :func:`demonstration_gaps` and the start-to-target length ``scale``."""
    z = -(beta / max(scale, 1e-9)) * np.asarray(gaps, dtype=np.float64)  # log-likelihood of each demonstration
    top = z.max(axis=(1, 2), keepdims=True)  # one shift per point keeps the goals' ratios
    likelihood = np.exp(z - top).mean(axis=2)  # (T, K)
    return likelihood / likelihood.sum(axis=1, keepdims=True)


def demonstration_posterior(traj, families, target: int, beta: float = DEMO_BETA) -> np.ndarray:
    """The belief of an observer who expects the demonstrations' own motion: (T, K).

    ``families`` (K, M, R, d) holds, for every goal, M demonstration-style paths to it (R points
    each: :func:`scdp.scoring.reference.goal_families`). A goal is as likely as the chance that
    one of its demonstrations passes where the path has been so far::

        P(g_k | s_1..s_t) ∝ (1/M) Σ_m exp(-b · δ_km(t)),   δ_km(t) = (1/t) Σ_{i<=t} min_r ||s_i - ρ_kmr||

    δ is the mean distance of the points seen so far from demonstration m to goal k; b = beta /
    ||g* - s_1||, so a mean distance of 1 / beta start-to-target lengths from every demonstration
    of a goal divides its odds by e. Every demonstration starts at the start, so the belief begins
    uniform, as the path-length observer's does.
    """
    traj = np.asarray(traj, dtype=np.float64)
    families = np.asarray(families, dtype=np.float64)
    scale = float(np.linalg.norm(families[target, 0, -1] - traj[0]))
    return demonstration_belief(demonstration_gaps(traj, families), scale, beta)


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
    fractions = np.asarray(fractions, dtype=np.float64)
    if np.any((fractions < 0.0) | (fractions > 1.0)):
        raise ValueError(f"a fraction of the motion lies in [0, 1], got {fractions.tolist()}")
    rows = posterior[np.rint(fractions * (len(posterior) - 1)).astype(int)]  # (F, K)
    others = np.delete(rows, target, axis=1).max(axis=1)
    return (rows[:, target] > others).tolist()


def observer_measures(traj, goals, target: int, *, beta: float = DEFAULT_BETA, threshold: float = CONFIDENCE,
                      fractions=FRACTIONS) -> dict:
    """Every observer measure of one path: ``time_to_confidence`` (``None``: never), and
    ``correct_at_<percent>`` for each fraction."""
    posterior = posterior_along(traj, goals, target, beta)
    measures: dict = {"time_to_confidence": time_to_confidence(posterior[:, target], threshold)}
    for f, ok in zip(fractions, correct_at(posterior, target, fractions)):
        measures[f"correct_at_{round(100 * f)}"] = ok
    return measures
