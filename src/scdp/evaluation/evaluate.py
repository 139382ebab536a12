"""Score executed rollouts and summarise them: the one evaluator for every method.

Each trajectory record holds the scene, the executed task-space path, success, the
per-scene normalisation bounds, ``j_hat``, every metric of :func:`scdp.reference.score_path`,
the style of each chunk and the amortised planning time.
"""

from __future__ import annotations

import numpy as np

from scdp import metrics, reference


def scene_bounds(task, goals, target, cache: dict | None = None, references: int = reference.DEFAULT_REFERENCES):
    """Reference bounds of a scene, memoised in ``cache`` by the scene's coordinates."""
    key = (np.round(np.asarray(goals), 6).tobytes(), int(target))
    if cache is not None and key in cache:
        return cache[key]
    b = reference.reference_bounds(task, goals, target, n=references)
    if cache is not None:
        cache[key] = b
    return b


def trajectory_record(task, run, *, method: str, scene_set: str, bounds, beta: float = metrics.DEFAULT_BETA) -> dict:
    path = np.asarray(run.path)
    m = reference.score_path(task, path, run.goals, run.target, bounds, beta=beta)
    return {
        "task": task.name, "scene_set": scene_set, "method": method,
        "goals": np.asarray(run.goals).tolist(), "target": int(run.target),
        "path": path.round(4).tolist(), "success": bool(run.success),
        "bounds": bounds.to_dict(), "j_hat": m["j_hat"],
        "metrics": {k: m[k] for k in ("detachment", "efficiency", "d_hat", "e_hat", "transparency", "legibility")},
        "beta": beta, "styles": list(run.styles), "seconds": float(run.seconds),
    }


def summarize(records: list[dict]) -> dict:
    """Mean and std of T, d_hat, e_hat, legibility, success and seconds over records."""
    def stat(values):
        v = np.asarray(values, dtype=np.float64)
        return {"mean": float(v.mean()), "std": float(v.std())} if len(v) else {"mean": float("nan"), "std": float("nan")}

    out = {k: stat([r["metrics"][k] for r in records]) for k in ("transparency", "d_hat", "e_hat", "legibility")}
    out["success"] = stat([float(r["success"]) for r in records])
    out["seconds"] = stat([r["seconds"] for r in records])
    out["n"] = len(records)
    styles = [s for r in records for s in r["styles"]]
    if styles:
        out["style_share"] = {s: styles.count(s) / len(styles) for s in sorted(set(styles))}
    return out


def random_scenes(task, n: int, seed: int) -> list[tuple[np.ndarray, int]]:
    """``n`` random two-goal scenes with a random target."""
    rng = np.random.default_rng(seed)
    return [(task.sample_goals(rng, 2), int(rng.integers(2))) for _ in range(n)]
