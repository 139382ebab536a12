"""Metric sensitivity: T rescored under two normalisations of the goal separation j.

T = (1 − w) D̂ + w Ê weighs detachment against efficiency by ``w = w_amb(ĵ)`` (eq. 8), where
``ĵ`` is the distance j from g* to its nearest distractor, min-max normalised over a range
``[lo, hi]`` and clipped to [0, 1]. The range is a free choice of the metric:

* ours (:func:`scdp.scoring.score.j_hat`): ``[min_goal_separation, diagonal of the goal box]``
  of the task (:func:`box_range`);
* the paper's: "with respect to the values obtained from the training dataset", i.e. the
  smallest and largest j over the training demonstrations' scenes (:func:`dataset_range`); when
  the dataset is not at hand, the range over the evaluation's random scenes stands in
  (:func:`scenes_range`), and the report says so.

Whatever the range, w lies in [w_amb(0), w_amb(1)] = [0.223, 0.777]. Everything here is rescored
from what the records store (path, goals, target, reference bounds: :func:`rescore`), never from
new rollouts, and both normalisations are shown side by side: neither is picked for agreeing.
:func:`paper_implied_weights` gives the single w that would turn the paper's mean D̂ and Ê
(Table 2) into its mean T (Table 1).
"""

from __future__ import annotations

from dataclasses import replace
from itertools import product

import numpy as np

from scdp import metrics, scoring
from scdp.errors import ScdpError
from scdp.evaluation.paper import PAPER_DE, PAPER_T
from scdp.evaluation.records import BOUNDED, FAILURE_AWARE, TrajectoryRecord, scene_key
from scdp.evaluation.statistics import PairedDifference, compare
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.tasks import Task, get_task

U, X0 = 2.5, 0.5  # eq. 8's steepness and midpoint, as scored (scdp.scoring.score.score_path)
W_MIN, W_MAX = float(metrics.ambiguity_weight(0.0, U, X0)), float(metrics.ambiguity_weight(1.0, U, X0))
HEADLINE_PAIRS = (("scdp", "dp"), ("scdp", "ld"), ("scdp", "dataset"), ("scdp", "scdp_paper"))
HEADLINE_METRICS = ("transparency", FAILURE_AWARE, BOUNDED)
METRIC_NAMES = {"transparency": "T", FAILURE_AWARE: "T_fa", BOUNDED: "T_b"}
OURS, ALTERNATIVE = "box_diagonal", "training_range"
PAPER_ROUNDING = 0.005  # the paper prints two decimals


def box_range(task: Task) -> tuple[float, float]:
    """Our range of j: the task's minimum goal separation to the diagonal of its goal box."""
    lo, hi = get_task(task).goal_distance_range()
    return float(lo), float(hi)


def scenes_range(scenes) -> tuple[float, float]:
    """(smallest, largest) goal separation j over scenes given as (goals, target) pairs."""
    j = [metrics.goal_separation(goals, target) for goals, target in scenes]
    if not j:
        raise ScdpError("scenes", "no scenes to take the range of j from")
    return float(min(j)), float(max(j))


def dataset_range(dataset) -> tuple[float, float]:
    """The range of j over a :class:`~scdp.data.dataset.DemoDataset`'s demonstrations (one scene each)."""
    starts = np.concatenate([[0], dataset.episode_ends[:-1]]).astype(int)
    return scenes_range((np.asarray(dataset.goals[a], dtype=np.float64), int(t))
                        for a, t in zip(starts, dataset.target_index))


def evaluation_range(records: list[TrajectoryRecord], task: str, scene_sets=(AMBIGUOUS, CLEAR)) -> tuple[float, float]:
    """The range of j over a task's evaluation scenes in ``scene_sets`` (each scene counted once)."""
    scenes = {scene_key(r, i): (r.goals, r.target) for i, r in enumerate(records)
              if r.task == task and r.scene_set in scene_sets}
    return scenes_range(scenes.values())


def path_scores(record: TrajectoryRecord) -> tuple[float, float]:
    """(D̂, Ê) of a record's stored path against its stored reference bounds."""
    if len(record.path) == 0:
        raise ScdpError("results", f"a {record.method} record of {record.task} stores no path: it cannot be rescored")
    return scoring.normalised_scores(get_task(record.task), np.asarray(record.path, dtype=np.float64), record.goals,
                                     record.target, scoring.Bounds(**record.bounds))


def weight(goals, target: int, j_range: tuple[float, float], *, u: float = U, x0: float = X0) -> tuple[float, float]:
    """(ĵ, w) of a scene when j is normalised over ``j_range``."""
    j_hat = float(metrics.normalised_goal_separation(metrics.goal_separation(goals, target), *j_range))
    return j_hat, float(metrics.ambiguity_weight(j_hat, u, x0))


def rescore(record: TrajectoryRecord, j_range: tuple[float, float], *, u: float = U, x0: float = X0,
            scores: tuple[float, float] | None = None) -> dict:
    """T, T_fa and T_b of a record with j normalised over ``j_range``: a pure function of the stored path,
    the scene, its reference bounds and the range. ``scores`` may pass (D̂, Ê) already computed."""
    d_hat, e_hat = scores if scores is not None else path_scores(record)
    j_hat, w = weight(record.goals, record.target, j_range, u=u, x0=x0)
    t = float(metrics.transparency(d_hat, e_hat, j_hat, u, x0))
    return {"d_hat": d_hat, "e_hat": e_hat, "j_hat": j_hat, "w": w, "transparency": t,
            FAILURE_AWARE: metrics.failure_aware_transparency(t, record.success),
            BOUNDED: metrics.bounded_transparency(d_hat, e_hat, j_hat, record.success, u, x0)}


def rescored(records: list[TrajectoryRecord], ranges: dict, scores: list | None = None) -> list[TrajectoryRecord]:
    """Copies of the records whose metrics (T, T_fa, T_b, D̂, Ê, ĵ, w) are rescored with j normalised over
    ``ranges[task]``; ``scores`` may give each record's (D̂, Ê) from :func:`path_scores`, in order."""
    scores = [path_scores(r) for r in records] if scores is None else scores
    out = []
    for r, pair in zip(records, scores, strict=True):
        m = rescore(r, ranges[r.task], scores=pair)
        out.append(replace(r, metrics={**r.metrics, **m}, j_hat=m["j_hat"]))
    return out


def _triple(c: PairedDifference) -> list[float]:
    return [c.mean, c.lo, c.hi]


def sensitivity(records: list[TrajectoryRecord], alternative: dict, sources: dict, *, scene_sets=(AMBIGUOUS, CLEAR),
                pairs=HEADLINE_PAIRS, metric_names=HEADLINE_METRICS) -> dict:
    """The headline paired differences under both normalisations, and the weights behind them.

    ``alternative[task]`` is the alternative j range of a task and ``sources[task]`` says where it
    came from. Returns ``ranges`` (per task: both ranges and the source), ``rows`` (task, scene
    set, pair, metric, ``ours`` and ``alternative`` as [mean, lo, hi]), ``weights`` (per task and
    scene set: min, max and mean w over its distinct scenes under each range), ``rescore_error``
    (largest |T rescored with our range − T stored|) and ``paper`` (:func:`paper_implied_weights`).
    """
    records = [r for r in records if r.scene_set in scene_sets]
    tasks = sorted({r.task for r in records})
    ranges = {OURS: {t: box_range(t) for t in tasks}, ALTERNATIVE: {t: tuple(alternative[t]) for t in tasks}}
    scores = [path_scores(r) for r in records]
    under = {name: rescored(records, ranges[name], scores) for name in (OURS, ALTERNATIVE)}
    error = max((abs(a.metrics["transparency"] - b.metrics["transparency"]) for a, b in zip(under[OURS], records)), default=0.0)
    rows, weights = [], []
    for task, s in product(tasks, scene_sets):
        group = {name: [r for r in rs if r.task == task and r.scene_set == s] for name, rs in under.items()}
        if not group[OURS]:
            continue
        methods = {r.method for r in group[OURS]}
        for (a, b), m in product(pairs, metric_names):
            if {a, b} <= methods:
                c = {name: compare(group[name], a, b, m) for name in group}
                rows.append({"task": task, "scene_set": s, "a": a, "b": b, "metric": m, "n": c[OURS].n,
                             OURS: _triple(c[OURS]), ALTERNATIVE: _triple(c[ALTERNATIVE])})
        entry = {"task": task, "scene_set": s}
        for name, rs in group.items():
            w = np.array(list({scene_key(r, i): r.metrics["w"] for i, r in enumerate(rs)}.values()))
            entry[name] = {"min": float(w.min()), "max": float(w.max()), "mean": float(w.mean()), "scenes": len(w)}
        weights.append(entry)
    return {"ranges": {t: {OURS: list(ranges[OURS][t]), ALTERNATIVE: list(ranges[ALTERNATIVE][t]), "source": sources[t]}
                       for t in tasks},
            "rows": rows, "weights": weights, "rescore_error": float(error), "paper": paper_implied_weights(tasks)}


def implied_weight(t: float, d: float, e: float, rounding: float = PAPER_ROUNDING) -> dict:
    """The w with ``t = (1 − w) d + w e``, and its range when each number is known to ± ``rounding``.

    ``w`` is None when E − D may be 0 within the rounding (no w follows from the numbers).
    """
    if abs(e - d) <= 2 * rounding:
        return {"w": None, "lo": None, "hi": None, "fits": None}
    corners = [(t + a - (d + b)) / (e + c - (d + b)) for a, b, c in product((-rounding, rounding), repeat=3)]
    lo, hi = min(corners), max(corners)
    return {"w": (t - d) / (e - d), "lo": lo, "hi": hi, "fits": hi >= W_MIN and lo <= W_MAX}


def paper_implied_weights(tasks=None) -> list[dict]:
    """For each task (of ``tasks``, default both of the paper's), method and scene set of the paper's
    Tables 1-2: the single w that turns its
    mean D̂ and Ê into its mean T (the mean of per-scene T equals it only if w were the same in
    every scene), its range under the two-decimal rounding, and whether a w in [0.223, 0.777] fits."""
    rows = []
    for task, methods in PAPER_T.items():
        if tasks is not None and task not in tasks:
            continue  # a task of your own has no paper numbers
        for method, by_set in methods.items():
            for i, s in enumerate((AMBIGUOUS, CLEAR)):
                (d, _), (e, _) = PAPER_DE[task][method][i]
                rows.append({"task": task, "method": method, "scene_set": s, "T": by_set[i][0], "D": d, "E": e,
                             **implied_weight(by_set[i][0], d, e)})
    return rows


def _cell(v: list[float]) -> str:
    star = " *" if v[1] > 0 or v[2] < 0 else ""
    return f"{v[0]:+.3f} [{v[1]:+.3f}, {v[2]:+.3f}]{star}"


def _verdict(v: list[float]) -> str:
    return "above 0" if v[1] > 0 else "below 0" if v[2] < 0 else "includes 0"


def sensitivity_markdown(result: dict) -> str:
    """The report's "Metric sensitivity" section body: ranges and weights, differences, paper weights."""
    lines = ["T = (1 − w) D̂ + w Ê with w = w_amb(ĵ) (eq. 8, u = 2.5, x0 = 0.5), ĵ = j min-max normalised over a range "
             "and clipped to [0, 1], j = distance from g* to its nearest distractor. **Ours** (every other table of this "
             "report): the range is [minimum goal separation, diagonal of the goal box]. **Alternative** (the paper's "
             "wording, \"with respect to the values obtained from the training dataset\"): the smallest and largest j "
             "over the training demonstrations' scenes; where the dataset is absent, over the evaluation's random scenes "
             "(column *source*). Both are rescored from the stored paths (largest |T rescored with our range − T stored| = "
             f"{result['rescore_error']:.1e}). Whatever the range, w lies in [{W_MIN:.3f}, {W_MAX:.3f}].", "",
             "| task | scene set | j range, ours | w min–max, ours | mean w, ours | j range, alternative | source | "
             "w min–max, alternative | mean w, alternative | scenes |", "|---|---|---|---|---|---|---|---|---|---|"]
    for w in result["weights"]:
        rng = result["ranges"][w["task"]]
        o, a = w[OURS], w[ALTERNATIVE]
        lines.append(f"| {w['task']} | {w['scene_set']} | [{rng[OURS][0]:.3f}, {rng[OURS][1]:.3f}] | {o['min']:.3f}–{o['max']:.3f} | "
                     f"{o['mean']:.3f} | [{rng[ALTERNATIVE][0]:.3f}, {rng[ALTERNATIVE][1]:.3f}] | {rng['source']} | "
                     f"{a['min']:.3f}–{a['max']:.3f} | {a['mean']:.3f} | {o['scenes']} |")
    lines += ["", "Headline paired differences under both ranges (95 % bootstrap intervals, * = excludes zero; "
              "T_fa = failure-aware T, which the claims and targets are judged on; T_b = bounded T, a sensitivity row: "
              "D̂ and Ê clipped to the reference range [0, 1] and a failure scoring 0, the scene's worst, so that no run "
              "scores below a failure):", "",
              "| task | scene set | difference | metric | pairs | ours (box diagonal) | alternative (range of *source*) | "
              "verdict ours / alternative |", "|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        metric = METRIC_NAMES[r["metric"]]
        lines.append(f"| {r['task']} | {r['scene_set']} | {r['a']} − {r['b']} | {metric} | {r['n']} | {_cell(r[OURS])} | "
                     f"{_cell(r[ALTERNATIVE])} | {_verdict(r[OURS])} / {_verdict(r[ALTERNATIVE])} |")
    if not result["paper"]:  # a task of your own: the paper has no numbers for it
        return "\n".join(lines) + "\n"
    lines += ["", f"The weight the paper's Tables 1-2 imply: w = (T − D̂) / (Ê − D̂) from its mean T, D̂ and Ê (a single w per "
              f"cell; the range allows ±{PAPER_ROUNDING} rounding of each number; *fits* = some w in that range lies in "
              f"[{W_MIN:.3f}, {W_MAX:.3f}]; n/a where Ê − D̂ is within rounding of 0):", "",
              "| task | method | scene set | T | D̂ | Ê | implied w | range under rounding | fits |",
              "|---|---|---|---|---|---|---|---|---|"]
    for p in result["paper"]:
        if p["w"] is None:
            implied, span, fits = "n/a", "n/a", "n/a"
        else:
            implied, span, fits = f"{p['w']:.2f}", f"[{p['lo']:.2f}, {p['hi']:.2f}]", "yes" if p["fits"] else "**no**"
        lines.append(f"| {p['task']} | {p['method']} | {p['scene_set']} | {p['T']:.2f} | {p['D']:.2f} | {p['E']:.2f} | "
                     f"{implied} | {span} | {fits} |")
    misfits = sum(p["fits"] is False for p in result["paper"])
    lines += ["", f"{misfits} of the paper's {len(result['paper'])} cells cannot come from one w in [{W_MIN:.3f}, {W_MAX:.3f}]."]
    return "\n".join(lines) + "\n"
