"""The paper's evaluation maths, as plain functions of task-space paths.

A path ``traj`` is an array (T, d) of task-space points ``s_1 .. s_T`` (t counts from 1).
Goals are (d,) points or (K, d) arrays. Nothing here knows about robots or datasets; the
per-scene normalisation lives in :mod:`scdp.scoring`.

About the observer temperature ``beta``: the paper and Dragan & Srinivasa (2013) fix no
value, and the raw exponent has units of 1/metre, so a fixed number would mean different
things for a 0.3 m arm reach and a 3 m drive. Here ``beta`` is *scale-free*: the exponent
uses ``beta / ||g* - S||``, i.e. costs are measured in units of the straight start-to-target
distance. ``beta = 4`` (the default) means that moving the full start-to-target distance
closer to one goal than to another multiplies its odds by e^4 ~ 55.
"""

from __future__ import annotations

import numpy as np

DEFAULT_BETA = 4.0
# the success rate every method must reach for a paper target, a claim, an observer target or a chosen
# setting to count (the real-time gate pre-registered its own: evaluation.noninferiority.GATE_MIN_SUCCESS)
MIN_SUCCESS = 0.98


def detachment(traj, negative_goal) -> float:
    """Detachment score, eq. 5: ``D = sum_{t=1..T} ||g- - s_t|| / t``.

    Large when the path leaves the neighbourhood of the distractor early. With several
    distractors (K, d), the nearest one (smallest D) is used.
    """
    traj = np.asarray(traj, dtype=np.float64)
    neg = np.atleast_2d(np.asarray(negative_goal, dtype=np.float64))
    t = np.arange(1, len(traj) + 1)
    dist = np.linalg.norm(traj[None, :, :] - neg[:, None, :], axis=-1)
    return float(np.min((dist / t).sum(axis=1)))


def path_length(traj) -> float:
    """``sum_t ||s_t - s_{t-1}||``: the length of a path of points (T, d)."""
    traj = np.asarray(traj, dtype=np.float64)
    return float(np.linalg.norm(np.diff(traj, axis=0), axis=1).sum())


def efficiency(traj, eps: float = 1e-6) -> float:
    """Trajectory efficiency, eq. 6: ``E = (sum_t ||s_t - s_{t-1}|| + eps)^-1`` (1 / :func:`path_length`)."""
    return float(1.0 / (path_length(traj) + eps))


def observer_posterior(points, start, goals, beta: float = DEFAULT_BETA, scale=None) -> np.ndarray:
    """Dragan's observer with path-length cost, closed form (REFERENCE §2).

    ``P(g | xi_{S->Q}) ∝ exp(-b (||g - Q|| - ||g - S||))`` with a uniform prior, where
    ``b = beta / scale`` (``scale`` defaults to 1 m). Points (..., T, d), start (..., d),
    goals (..., K, d) and scale (...) -> (..., T, K); the leading ``...`` are scenes.
    """
    points = np.asarray(points, dtype=np.float64)
    start = np.asarray(start, dtype=np.float64)
    goals = np.asarray(goals, dtype=np.float64)
    b = beta / (np.ones(()) if scale is None else np.asarray(scale, dtype=np.float64))
    cost = (np.linalg.norm(goals[..., None, :, :] - points[..., :, None, :], axis=-1)
            - np.linalg.norm(goals - start[..., None, :], axis=-1)[..., None, :])  # (..., T, K)
    logits = -b[..., None, None] * cost
    logits -= logits.max(axis=-1, keepdims=True)
    p = np.exp(logits)
    return p / p.sum(axis=-1, keepdims=True)


def time_weights(n: int) -> np.ndarray:
    """Dragan's weighting ``f(t) = T - t`` for t = 0..T-1 (early points weigh most)."""
    return np.arange(n, 0, -1, dtype=np.float64)


def legibility(traj, goals, target_index: int, beta: float = DEFAULT_BETA, start=None) -> float:
    """Legibility, eq. 2: ``sum_t P(g* | xi_{S->s_t}) f(t) / sum_t f(t)`` with ``f(t) = T - t``.

    ``start`` defaults to the first point of ``traj``. ``beta`` is scale-free (see module
    docstring): the observer uses ``beta / ||g* - S||``. Chance level is 1/K for K goals.
    """
    traj = np.asarray(traj, dtype=np.float64)
    goals = np.asarray(goals, dtype=np.float64)
    start = traj[0] if start is None else np.asarray(start, dtype=np.float64)
    scale = max(float(np.linalg.norm(goals[target_index] - start)), 1e-9)
    p = observer_posterior(traj, start, goals, beta, scale)[:, target_index]
    f = time_weights(len(traj))
    return float((p * f).sum() / f.sum())


def ambiguity_weight(j_hat, u: float = 2.5, x0: float = 0.5):
    """Eq. 8: ``w_amb(j) = 1 / (1 + exp(-u (j_hat - x0)))`` of the normalised goal distance."""
    return 1.0 / (1.0 + np.exp(-u * (np.asarray(j_hat, dtype=np.float64) - x0)))


def transparency(d_hat, e_hat, j_hat, u: float = 2.5, x0: float = 0.5):
    """Adaptive transparency score, eq. 7: ``T = (1 - w_amb) D_hat + w_amb E_hat``.

    Close goals (small j_hat) reward detachment; far-apart goals reward efficiency.
    """
    w = ambiguity_weight(j_hat, u, x0)
    return (1.0 - w) * np.asarray(d_hat, dtype=np.float64) + w * np.asarray(e_hat, dtype=np.float64)


def failure_aware_transparency(t, success):
    """The failure-aware score ``T_fa``: T for a successful run, ``min(T, 0)`` for a failed one.

    Why 0: D̂ and Ê are min-max normalised over the scene's reference demonstrations, so every
    reference path has D̂ and Ê in [0, 1] and hence T in [0, 1] whatever the weight; 0 is the
    score of a path as poor as the worst reference on both. A failed run is therefore never
    credited more than that floor (raw T can credit a failed detour with T > 1). Successful runs
    *can* score below 0 (a detour beyond every reference path), so a plain 0 would rank a
    failure above such a success; a failed run whose own T is already below 0 keeps its T.
    Works elementwise on arrays; returns a float for scalars.
    """
    t = np.asarray(t, dtype=np.float64)
    out = np.where(np.asarray(success, dtype=bool), t, np.minimum(t, 0.0))
    return float(out) if out.ndim == 0 else out


def bounded_transparency(d_hat, e_hat, j_hat, success, u: float = 2.5, x0: float = 0.5):
    """The bounded score ``T_b``, a sensitivity variant of :func:`failure_aware_transparency`: D̂ and Ê
    clipped to the reference range [0, 1] before they are weighed (eq. 7), and a failed run scoring
    0, the scene's worst. T_b lies in [0, 1]; no run, failed or not, can score below a failure or
    above the best reference path. Works elementwise on arrays; returns a float for scalars."""
    t = transparency(np.clip(d_hat, 0.0, 1.0), np.clip(e_hat, 0.0, 1.0), j_hat, u, x0)
    out = np.where(np.asarray(success, dtype=bool), t, 0.0)
    return float(out) if out.ndim == 0 else out


def goal_separation(goals, target_index: int) -> float:
    """The raw goal separation j: distance from g* to its nearest distractor (task-space units)."""
    goals = np.asarray(goals, dtype=np.float64)
    return float(np.min(np.linalg.norm(np.delete(goals, target_index, axis=0) - goals[target_index], axis=1)))


def normalised_goal_separation(j, lo: float, hi: float):
    """``j_hat``: the separation min-max normalised over a range ``[lo, hi]`` and clipped to [0, 1].

    The range is the free choice of the metric: :func:`scdp.scoring.score.j_hat` uses the task's
    ``[min_goal_separation, diagonal of the goal box]``; the paper normalises over the training
    dataset's values (:mod:`scdp.evaluation.sensitivity` scores both).
    """
    return np.clip(min_max(j, lo, hi), 0.0, 1.0)


def success(traj, target, radius: float) -> bool:
    """True when any point of the path comes within ``radius`` of ``target``."""
    traj = np.asarray(traj, dtype=np.float64)
    return bool(np.min(np.linalg.norm(traj - np.asarray(target, dtype=np.float64), axis=1)) < radius)


def min_max(value, lo: float, hi: float):
    """Min-max normalisation ``(value - lo) / (hi - lo)``, unclipped (may leave [0, 1])."""
    span = hi - lo
    return (np.asarray(value, dtype=np.float64) - lo) / (span if abs(span) > 1e-12 else 1e-12)


def resample(traj, n: int = 200) -> np.ndarray:
    """Resample a path to ``n`` points, linearly in time (index), as the authors did for D."""
    traj = np.asarray(traj, dtype=np.float64)
    src = np.linspace(0.0, 1.0, len(traj))
    dst = np.linspace(0.0, 1.0, n)
    return np.column_stack([np.interp(dst, src, traj[:, k]) for k in range(traj.shape[1])])


def truncate_at_goal(traj, target, radius: float) -> np.ndarray:
    """The path up to and including its first point within ``radius`` of ``target``.

    A rollout stops as soon as it enters the success radius; cutting reference paths the
    same way keeps normalised scores comparable (REFERENCE §6).
    """
    traj = np.asarray(traj, dtype=np.float64)
    inside = np.flatnonzero(np.linalg.norm(traj - np.asarray(target, dtype=np.float64), axis=1) < radius)
    return traj if inside.size == 0 else traj[: inside[0] + 1]
