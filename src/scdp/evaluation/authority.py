"""Style authority along the motion: how much a style chosen part-way through a motion still moves the robot.

SCDP re-decides its style at every replan, so a style switched on mid-motion should shape the rest of it as one
chosen at the start shapes the whole. For each scene, the *unswitched* run holds style ``first`` throughout; a
*switched* run holds ``first`` until the robot has taken ``round(f N)`` actions (N: the unswitched run's length,
f a fraction of the motion) and ``then`` from there on; both through the public
:class:`~scdp.policies.control.ControlLoopPolicy` with one seed, so the same scene and the same noise. Per
fraction, over the part of the motion after the switch point:

* ``separation``: the median task-space distance between the switched and the unswitched path, step by step
  (the shorter one held at its end);
* ``gain``: what the path-length observer reads of that part (:func:`scdp.evaluation.dynamic.segment_measures`),
  the legible-styled run minus the efficient-styled one;
* ``detour``: that part's length to the goal over its straight distance, switched and unswitched.

A style with authority all along keeps, at f = 0.3, a good share of what it does at f = 0 (the ratio columns).
"""

from __future__ import annotations

import numpy as np

from scdp.evaluation.dynamic import EFFICIENT, LEGIBLE, segment_measures
from scdp.policies.control import ControlLoopPolicy
from scdp.tasks import Task

SWITCH_FRACTIONS = (0.0, 0.15, 0.3, 0.5, 0.7)  # of the motion, where the style is switched
DIRECTIONS = ((EFFICIENT, LEGIBLE), (LEGIBLE, EFFICIENT))  # (held first, switched to)
NOTHING = 1e-9  # a separation or observer gain at the switch at 0 no larger than this is none: no ratio to it


def drive(task: Task, planner, goals, target: int, seed: int, first: str, then: str | None = None,
          at: int | None = None) -> np.ndarray:
    """The task-space path (N + 1, G) of one episode planned with style ``first``, switched to ``then`` once ``at``
    actions were taken (None: never), as a robot's loop would (:class:`ControlLoopPolicy`, seed ``seed``)."""
    env = task.make_env()
    obs, _ = env.reset(seed=seed, options={"goals": goals, "target": int(target)})
    planner.set_style(first)
    policy = ControlLoopPolicy(planner, task, goals, target, seed=seed)
    policy.reset(obs["state"])
    path = [env.position.copy()]
    while True:
        if at is not None and len(path) - 1 == at:
            policy.set_style(then)
        obs, _, terminated, truncated, info = env.step(policy.select_action(obs["state"]))
        path.append(info["position"])
        if terminated or truncated:
            return np.asarray(path, dtype=np.float64)


def separation(a: np.ndarray, b: np.ndarray, start: int) -> float:
    """Median distance between paths ``a`` and ``b`` step by step from ``start`` on (the shorter held at its end)."""
    n = max(len(a), len(b))
    pad = [np.vstack([p, np.repeat(p[-1:], n - len(p), axis=0)]) for p in (a, b)]
    return float(np.median(np.linalg.norm(pad[0][start:] - pad[1][start:], axis=1)))


def scene_authority(task: Task, planner, goals, target: int, seed: int, fractions=SWITCH_FRACTIONS) -> list[dict]:
    """One record per direction and fraction for one scene (module docstring)."""
    out = []
    for first, then in DIRECTIONS:
        base = drive(task, planner, goals, target, seed, first)
        for f in fractions:
            at = int(round(f * (len(base) - 1)))
            switched = drive(task, planner, goals, target, seed, first, then, at)
            out.append(switch_record(task, switched, base, at, goals, target, first, then, f))
    return out


def switch_record(task: Task, switched: np.ndarray, base: np.ndarray, at: int, goals, target: int, first: str,
                  then: str, fraction: float) -> dict:
    """What a switch from ``first`` to ``then`` after ``at`` steps did: ``switched`` against the held path ``base``
    (the module docstring's measures)."""
    (seen_s, detour_s), (seen_b, detour_b) = (segment_measures(task, p[at:], goals, target) for p in (switched, base))
    return {"first": first, "then": then, "fraction": fraction, "at": at, "steps": len(base) - 1,
            "separation": separation(switched, base, at), "gain": seen_s - seen_b if then == LEGIBLE else seen_b - seen_s,
            "detour_switched": detour_s, "detour_unswitched": detour_b}


def summarise(records: list[dict]) -> list[dict]:
    """Per direction and fraction: the median separation and mean observer gain over scenes, each with its ratio
    to the same direction's switch at 0, and the mean detours."""
    rows = []
    for first, then in DIRECTIONS:
        mine = [r for r in records if r["first"] == first]
        at_start = {}
        for f in sorted({r["fraction"] for r in mine}):
            group = [r for r in mine if r["fraction"] == f]
            row = {"first": first, "then": then, "fraction": f, "scenes": len(group),
                   "separation": float(np.median([r["separation"] for r in group])),
                   "gain": float(np.nanmean([r["gain"] for r in group])),
                   "detour_switched": float(np.nanmean([r["detour_switched"] for r in group])),
                   "detour_unswitched": float(np.nanmean([r["detour_unswitched"] for r in group]))}
            at_start = at_start or row
            for k in ("separation", "gain"):
                row[f"{k}_ratio"] = row[k] / at_start[k] if abs(at_start[k]) > NOTHING else float("nan")  # none at 0: no ratio
            rows.append(row)
    return rows


def table_lines(rows: list[dict]) -> list[str]:
    """:func:`summarise`'s rows as a markdown table, one line per direction and fraction."""
    return ["| switch | at | separation (m) | ratio | observer gain | ratio | detour switched | detour unswitched |",
            "|---|---|---|---|---|---|---|---|"] + [
        f"| {r['first']} → {r['then']} | {r['fraction']:.2f} | {r['separation']:.4f} | {r['separation_ratio']:.3f} | "
        f"{r['gain']:+.3f} | {r['gain_ratio']:.2f} | {r['detour_switched']:.3f} | {r['detour_unswitched']:.3f} |"
        for r in rows]
