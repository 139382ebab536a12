"""Spatial ambiguity: the paper's probabilistic definition (eq. 3) and its ellipse proxy.

Both work in task space on the robot's current point ``s`` (the start, or the state at a
replanning step), the target ``g*`` and one or more distractors ``g-``.

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

Per-task calibrated values of ``beta``, ``tau``, ``kappa`` and ``ecc`` are in
``task.ambiguity``; :func:`calibrate` re-derives them.
"""

from __future__ import annotations

import itertools
from dataclasses import asdict, replace

import numpy as np

from scdp.errors import ScdpError, finite_array
from scdp.metrics import observer_posterior, time_weights

PATH_POINTS = 200


def straight_margin(start, goals, target_index: int, beta: float, n: int = PATH_POINTS) -> float:
    """f(t)-weighted mean of ``P(g*) - max P(g-)`` along the straight path ``start -> g*``."""
    return float(straight_margins(np.asarray(start)[None], np.asarray(goals)[None], np.array([target_index]), beta, n)[0])


def straight_margins(starts, goals, targets, beta: float, n: int = PATH_POINTS) -> np.ndarray:
    """Vectorised :func:`straight_margin` over B scenes: starts (B, d), goals (B, K, d), targets (B,)."""
    starts = np.asarray(starts, dtype=np.float64)
    goals = np.asarray(goals, dtype=np.float64)
    B, K, _ = goals.shape
    g_star = goals[np.arange(B), targets]
    scale = np.maximum(np.linalg.norm(g_star - starts, axis=-1), 1e-9)  # (B,)
    s = np.linspace(0.0, 1.0, n)
    points = starts[:, None] + s[None, :, None] * (g_star - starts)[:, None]  # (B, n, d)
    cost = np.linalg.norm(goals[:, None] - points[:, :, None], axis=-1) - np.linalg.norm(goals - starts[:, None], axis=-1)[:, None]
    logits = -(beta / scale)[:, None, None] * cost  # (B, n, K)
    logits -= logits.max(axis=-1, keepdims=True)
    p = np.exp(logits)
    p /= p.sum(axis=-1, keepdims=True)
    p_star = p[np.arange(B), :, targets]  # (B, n)
    mask = np.ones((B, K), dtype=bool)
    mask[np.arange(B), targets] = False
    p_neg = np.where(mask[:, None, :], p, -np.inf).max(axis=-1)
    f = time_weights(n)
    return ((p_star - p_neg) * f).sum(axis=1) / f.sum()


def ellipse(focus, target, kappa: float, eccentricity: float) -> tuple[np.ndarray, np.ndarray]:
    """Centre ``e`` (d,) and matrix ``M`` (d, d) of the ellipse of ambiguity."""
    if not 0.5 < kappa < 1.0:
        raise ScdpError("kappa", f"must lie in (0.5, 1), got {kappa}")
    if not 0.0 < eccentricity < 1.0:
        raise ScdpError("eccentricity", f"must lie in (0, 1), got {eccentricity}")
    focus = np.asarray(focus, dtype=np.float64)
    axis = np.asarray(target, dtype=np.float64) - focus
    dist = max(float(np.linalg.norm(axis)), 1e-9)
    u = axis / dist
    a = kappa * dist / eccentricity
    b = a * np.sqrt(1.0 - eccentricity**2)
    M = np.eye(len(focus)) / b**2 + (1.0 / a**2 - 1.0 / b**2) * np.outer(u, u)
    return focus + kappa * axis, M


def in_ellipse(point, center, M) -> bool:
    """``(p - e)^T M (p - e) <= 1``."""
    r = np.asarray(point, dtype=np.float64) - center
    return bool(r @ M @ r <= 1.0)


def ellipse_flags(starts, goals, targets, kappa: float, eccentricity: float) -> np.ndarray:
    """Vectorised ellipse test over B scenes (see :func:`straight_margins` for shapes)."""
    starts = np.asarray(starts, dtype=np.float64)
    goals = np.asarray(goals, dtype=np.float64)
    B, K, d = goals.shape
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
    return (q <= 1.0).any(axis=1)


def is_ambiguous(state_point, target, negatives, *, settings, method: str = "ellipse", **overrides) -> bool:
    """Is the scene ambiguous seen from ``state_point`` (a task-space point)?

    ``method="ellipse"`` uses the run-time proxy, ``method="probabilistic"`` eq. 3.
    ``settings`` is an :class:`scdp.tasks.AmbiguitySettings`, usually ``task.ambiguity``;
    keyword ``overrides`` (``beta``, ``tau``, ``kappa``, ``eccentricity``) replace its fields.
    """
    s = finite_array(state_point, "state")
    g = finite_array(target, "target", s.shape)
    neg = np.atleast_2d(finite_array(negatives, "negatives"))
    if neg.shape[1] != s.shape[0]:
        raise ScdpError("negatives", f"expected points of dimension {s.shape[0]}, got {neg.shape[1]}")
    settings = replace(settings, **overrides)
    goals = np.vstack([g, neg])
    if method == "ellipse":
        return bool(ellipse_flags(s[None], goals[None], np.array([0]), settings.kappa, settings.eccentricity)[0])
    if method == "probabilistic":
        return straight_margin(s, goals, 0, settings.beta) < settings.tau
    raise ScdpError("method", f"unknown ambiguity method {method!r} (ellipse or probabilistic)")


# ---------------------------------------------------------------------------------------
# Calibration against the authors' labels and agreement on random scenes.


def fixed_scenes(task):
    """The six configurations with both targets: starts (12, d), goals (12, 2, d), targets, labels, ids."""
    goals = np.repeat(task.fixed_configs, 2, axis=0)
    targets = np.tile([0, 1], len(task.fixed_configs))
    ids = np.repeat(np.arange(1, len(task.fixed_configs) + 1), 2)
    labels = np.isin(ids, task.ambiguous_configs)
    starts = np.repeat(task.start_point[None], len(goals), axis=0)
    return starts, goals, targets, labels, ids


def random_scenes(task, n: int, seed: int):
    """``n`` random two-goal scenes from the task's sampling box: starts, goals, targets."""
    from scdp.evaluation.evaluate import random_scenes as sample

    scenes = sample(task, n, seed)
    goals = np.stack([g for g, _ in scenes])
    targets = np.array([t for _, t in scenes])
    starts = np.repeat(task.start_point[None], n, axis=0)
    return starts, goals, targets


def calibrate(task, *, n_random: int = 10_000, seed: int = 0, beta: float | None = None) -> dict:
    """Fit ``tau`` and the ellipse to the authors' labels; report agreement on random scenes.

    ``tau`` is placed midway in the widest gap that splits the twelve labelled scenes (six
    configurations, both targets); if no value splits them, the one with fewest errors is
    taken. Among ellipses (kappa, eccentricity on a grid) that match the labels best, the one
    that agrees most often with the probabilistic definition on ``n_random`` scenes wins.
    """
    base = task.ambiguity if beta is None else replace(task.ambiguity, beta=beta)
    starts, goals, targets, labels, ids = fixed_scenes(task)
    margins = straight_margins(starts, goals, targets, base.beta)
    cands = np.sort(np.concatenate([margins, [margins.min() - 0.05, margins.max() + 0.05]]))
    mids = (cands[:-1] + cands[1:]) / 2
    errors = np.array([np.sum((margins < t) != labels) for t in mids])
    gaps = np.diff(cands)
    best = np.flatnonzero(errors == errors.min())
    tau = float(mids[best[np.argmax(gaps[best])]])

    r_starts, r_goals, r_targets = random_scenes(task, n_random, seed)
    prob = straight_margins(r_starts, r_goals, r_targets, base.beta) < tau
    best_key, best_ellipse = None, None
    for kappa, ecc in itertools.product(np.arange(0.55, 0.991, 0.02), np.arange(0.50, 0.991, 0.01)):
        errs = int(np.sum(ellipse_flags(starts, goals, targets, kappa, ecc) != labels))
        agree = float(np.mean(ellipse_flags(r_starts, r_goals, r_targets, kappa, ecc) == prob))
        key = (-errs, agree)
        if best_key is None or key > best_key:
            best_key, best_ellipse = key, (round(float(kappa), 2), round(float(ecc), 2))
    settings = replace(base, tau=round(tau, 4), kappa=best_ellipse[0], eccentricity=best_ellipse[1])
    return {"settings": settings, **agreement_report(task, settings, n_random=n_random, seed=seed)}


def agreement_report(task, settings, *, n_random: int = 10_000, seed: int = 0) -> dict:
    """How the two definitions label the fixed configurations and agree on random scenes."""
    starts, goals, targets, labels, ids = fixed_scenes(task)
    margins = straight_margins(starts, goals, targets, settings.beta)
    ell = ellipse_flags(starts, goals, targets, settings.kappa, settings.eccentricity)
    fixed = [
        {
            "config": int(i), "target": int(t), "authors_label": "ambiguous" if lab else "not ambiguous",
            "margin": round(float(m), 4), "probabilistic": bool(m < settings.tau), "ellipse": bool(e),
        }
        for i, t, lab, m, e in zip(ids, targets, labels, margins, ell)
    ]
    r_starts, r_goals, r_targets = random_scenes(task, n_random, seed)
    prob = straight_margins(r_starts, r_goals, r_targets, settings.beta) < settings.tau
    el = ellipse_flags(r_starts, r_goals, r_targets, settings.kappa, settings.eccentricity)
    return {
        "fixed": fixed,
        "fixed_mismatches": {
            "probabilistic": [f"config_{r['config']}/target_{r['target']}" for r in fixed if r["probabilistic"] != (r["authors_label"] == "ambiguous")],
            "ellipse": [f"config_{r['config']}/target_{r['target']}" for r in fixed if r["ellipse"] != (r["authors_label"] == "ambiguous")],
        },
        "random": {
            "scenes": int(n_random),
            "seed": int(seed),
            "agreement": float(np.mean(prob == el)),
            "both_ambiguous": int(np.sum(prob & el)),
            "both_clear": int(np.sum(~prob & ~el)),
            "only_probabilistic": int(np.sum(prob & ~el)),
            "only_ellipse": int(np.sum(~prob & el)),
            "ambiguous_rate_probabilistic": float(np.mean(prob)),
            "ambiguous_rate_ellipse": float(np.mean(el)),
        },
    }


def ambiguity_report(task, *, n_random: int = 10_000, seed: int = 0) -> dict:
    """Re-run the calibration and report the task's stored settings against it."""
    from scdp.tasks import get_task

    task = get_task(task)
    if n_random < 1:
        raise ScdpError("--scenes", f"must be at least 1, got {n_random}")
    calibrated = calibrate(task, n_random=n_random, seed=seed)["settings"]
    return {
        "task": task.name,
        "command": f"scdp ambiguity-report --task {task.name} --scenes {n_random} --seed {seed}",
        "stored_settings": asdict(task.ambiguity),
        "calibrated_settings": asdict(calibrated),
        "stored_match_calibration": asdict(calibrated) == asdict(task.ambiguity),
        **agreement_report(task, task.ambiguity, n_random=n_random, seed=seed),
    }


def report_markdown(report: dict) -> str:
    """Human-readable version of :func:`scdp.ambiguity.ambiguity_report`."""
    lines = [f"# Ambiguity report: {report['task']}", "", f"Command: `{report['command']}`", ""]
    s = report["stored_settings"]
    lines += [
        f"Stored settings: beta={s['beta']} (scale-free), tau={s['tau']}, kappa={s['kappa']}, eccentricity={s['eccentricity']}",
        f"Calibration finds: {report['calibrated_settings']} — {'matches' if report['stored_match_calibration'] else 'DIFFERS FROM'} the stored settings",
        "",
        "| config | target | authors | margin | probabilistic | ellipse |",
        "|---|---|---|---|---|---|",
    ]
    for r in report["fixed"]:
        yn = {True: "ambiguous", False: "clear"}
        lines.append(f"| {r['config']} | {r['target']} | {r['authors_label']} | {r['margin']:.3f} | {yn[r['probabilistic']]} | {yn[r['ellipse']]} |")
    m = report["fixed_mismatches"]
    lines += ["", f"Mismatches with the authors' labels: probabilistic {m['probabilistic'] or 'none'}, ellipse {m['ellipse'] or 'none'}", ""]
    r = report["random"]
    lines += [
        f"On {r['scenes']} random scenes (seed {r['seed']}): the ellipse agrees with eq. 3 on {100 * r['agreement']:.1f} %.",
        f"Ambiguous by eq. 3: {100 * r['ambiguous_rate_probabilistic']:.1f} %; by the ellipse: {100 * r['ambiguous_rate_ellipse']:.1f} %.",
        f"Both ambiguous {r['both_ambiguous']}, both clear {r['both_clear']}, only eq. 3 {r['only_probabilistic']}, only ellipse {r['only_ellipse']}.",
        "",
    ]
    return "\n".join(lines)
