"""What an observer reads from each method's paths: time to confidence and prediction accuracy.

Computed from the stored paths of a ``results.json`` (nothing is rolled out again) with the
measures of :mod:`scdp.observers`, on the path each record was scored on
(:func:`scdp.scoring.observed_path`). Three observers are declared here (:data:`OBSERVERS`, each
read through a :class:`Belief`), and every table names its observer and β: the path-length
observer at the record's own ``beta``, the demonstration observer at
:data:`scdp.observers.DEMO_BETA`, and the viewpoint observer, the path-length observer at the
record's ``beta`` applied to the path and goals projected into the view of a person watching the
robot (:func:`scdp.perception.as_seen`; a task without a viewer is watched from above, and
there it is the path-length observer).

* :func:`observer_summary`: per task, scene set and method, the share of runs that never become
  confident (reported apart, never averaged in), the median time to confidence of the others,
  the share of correct predictions at 25, 50 and 75 % of the motion, and the accuracy curve;
* :func:`observer_differences`: paired differences against a baseline on the same scenes and noise,
  95 % bootstrap intervals (scenes resampled where they repeat, :func:`scdp.evaluation.statistics.compare_values`).
"""

from __future__ import annotations

import copy

import numpy as np

from scdp import metrics, observers
from scdp.evaluation.records import TrajectoryRecord
from scdp.evaluation.statistics import MIN_STARRED, compare_values
from scdp.keys import AMBIGUOUS, CLEAR, LD_METHODS
from scdp.perception import as_seen
from scdp.scoring import goal_families, observed_path
from scdp.tasks import Task, get_task

PATH_LENGTH, DEMONSTRATION, VIEWPOINT = "path_length", "demonstration", "viewpoint"
OBSERVERS = {PATH_LENGTH: "path-length observer (Dragan & Srinivasa 2013)",
             DEMONSTRATION: "demonstration observer (expects the demonstrations' own motion)",
             VIEWPOINT: "viewpoint observer (the path-length observer on the motion as a person sees it)"}
# the temperatures every report also shows each observer under (the metric's free choice; docs/observers.md)
TEMPERATURES = {PATH_LENGTH: (2.0, 4.0, 8.0), DEMONSTRATION: (10.0, 20.0, 40.0), VIEWPOINT: (2.0, 4.0, 8.0)}
STRAIGHT_POINTS = 50  # the straight path to g* that tells whether a scene caps the observer
CURVE = np.linspace(0.0, 1.0, 21)  # fractions of the motion of the accuracy curve
SCENE_SETS = (AMBIGUOUS, CLEAR)  # the random scene sets the measures are reported on
ACCURACY_AT = tuple(round(100 * f) for f in observers.FRACTIONS)  # 25, 50, 75
COMPARED = (*LD_METHODS, "scdp", "scdp_blend", "scdp_paper")  # against DP; forced styles and the dataset are in the tables
MEASURES = (*(f"correct_at_{p}" for p in ACCURACY_AT), "never_confident", "time_to_confidence")


class Belief:
    """One observer's belief along each record's stored path (cut at the goal, resampled to 200
    points, :func:`scdp.scoring.observed_path`). ``beta`` None: the path-length observer takes each
    record's own β, the demonstration observer :data:`scdp.observers.DEMO_BETA`. The demonstration
    observer's families (:func:`scdp.scoring.goal_families`) are drawn once per scene."""

    def __init__(self, observer: str = PATH_LENGTH, beta: float | None = None):
        if observer not in OBSERVERS:
            raise ValueError(f"unknown observer {observer!r} (choose from {', '.join(OBSERVERS)})")
        self.observer, self.beta = observer, beta
        self._families: dict = {}  # per scene (task, goals)
        self._gaps: dict = {}  # per path: the demonstration observer's δ, whatever the temperature

    def with_beta(self, beta: float) -> Belief:
        """The same observer at another temperature (sharing the families already drawn)."""
        other = Belief(self.observer, beta)
        other._families, other._gaps = self._families, self._gaps
        return other

    def beta_of(self, record: TrajectoryRecord) -> float:
        if self.beta is not None:
            return self.beta
        return observers.DEMO_BETA if self.observer == DEMONSTRATION else record.beta

    def families(self, task: Task, goals: np.ndarray) -> np.ndarray:
        key = (task.name, goals.tobytes())
        if key not in self._families:
            self._families[key] = goal_families(task, goals)
        return self._families[key]

    def path(self, record: TrajectoryRecord) -> tuple[np.ndarray, np.ndarray]:
        task = get_task(record.task)
        goals = np.asarray(record.goals, dtype=np.float64)
        return observed_path(task, np.asarray(record.path, dtype=np.float64), goals, record.target), goals

    def along(self, record: TrajectoryRecord, path: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """(T, K): the belief along ``path`` in the record's scene."""
        return self.along_scene(get_task(record.task), path, goals, record.target, self.beta_of(record))

    def along_scene(self, task: Task, path: np.ndarray, goals: np.ndarray, target: int, beta: float) -> np.ndarray:
        """(T, K): the belief along an observed ``path`` (:func:`scdp.scoring.observed_path`) of one scene
        at temperature ``beta``, whatever holds the path (a record, a study's stimulus)."""
        if self.observer == PATH_LENGTH:
            return observers.posterior_along(path, goals, target, beta)
        if self.observer == VIEWPOINT:
            return observers.posterior_along(as_seen(task, path), as_seen(task, goals), target, beta)
        key = (task.name, goals.tobytes(), path.tobytes())
        if key not in self._gaps:
            self._gaps[key] = observers.demonstration_gaps(path, self.families(task, goals))
        scale = float(np.linalg.norm(goals[target] - path[0]))
        return observers.demonstration_belief(self._gaps[key], scale, beta)

    def default_beta(self) -> float:
        """The temperature this observer reads a path at when nothing sets one: the legibility metric's
        β (:data:`scdp.metrics.DEFAULT_BETA`), the demonstration observer's own for that one."""
        return self.beta if self.beta is not None else observers.DEMO_BETA if self.observer == DEMONSTRATION \
            else metrics.DEFAULT_BETA


def record_measures(record: TrajectoryRecord, threshold: float = observers.CONFIDENCE, belief: Belief | None = None) -> dict:
    """``time_to_confidence`` (NaN: never confident), ``correct`` (bool at each :data:`CURVE` fraction)
    and ``capped``: even the straight path from the record's start to g* ends with the observer's
    belief below the threshold (the scene's goals are too close for this observer)."""
    belief = belief or Belief()
    path, goals = belief.path(record)
    posterior = belief.along(record, path, goals)
    ttc = observers.time_to_confidence(posterior[:, record.target], threshold)
    straight = np.linspace(path[0], goals[record.target], STRAIGHT_POINTS)  # a path that ends on g*
    at_target = belief.along(record, straight, goals)
    return {"time_to_confidence": np.nan if ttc is None else ttc,
            "correct": observers.correct_at(posterior, record.target, CURVE),
            "capped": bool(at_target[-1, record.target] < threshold)}


def curve_index(percent: int) -> int:
    """The point of :data:`CURVE` at ``percent`` % of the motion."""
    return int(np.argmin(np.abs(CURVE - percent / 100)))


class Measured:
    """The records of some scene sets with their observer measures, computed once each."""

    def __init__(self, records: list[TrajectoryRecord], threshold: float = observers.CONFIDENCE, scene_sets=SCENE_SETS,
                 belief: Belief | None = None):
        self.records = [r for r in records if r.scene_set in scene_sets]
        self.threshold = threshold
        self.belief = belief or Belief()
        self._measures = {id(r): record_measures(r, threshold, self.belief) for r in self.records}

    def of(self, record: TrajectoryRecord) -> dict:
        return self._measures[id(record)]

    def read_through(self, originals: list[TrajectoryRecord], copies: list[TrajectoryRecord]) -> Measured:
        """The same measures read through copies of the records (the same paths scored otherwise:
        :func:`scdp.evaluation.normalised.under`), ``copies[i]`` reading ``originals[i]``'s."""
        other = copy.copy(self)
        pairs = [(o, c) for o, c in zip(originals, copies, strict=True) if id(o) in self._measures]
        other.records = [c for _, c in pairs]
        other._measures = {id(c): self._measures[id(o)] for o, c in pairs}
        return other

    def correct_at(self, percent: int):
        """A record's 0/1 prediction at ``percent`` % of the motion (a point of :data:`CURVE`)."""
        k = curve_index(percent)
        return lambda r: float(self.of(r)["correct"][k])

    def never(self, record: TrajectoryRecord) -> float:
        return float(np.isnan(self.of(record)["time_to_confidence"]))

    def time_to_confidence(self, record: TrajectoryRecord) -> float:
        return self.of(record)["time_to_confidence"]


def observer_summary(measured: Measured) -> dict:
    """``{task: {scene set: {method: {...}}}}``: runs, never-confident share, median time to
    confidence of the confident runs (``None`` when none is), accuracy at 25/50/75 % and the curve."""
    out: dict = {}
    for r in measured.records:
        out.setdefault(r.task, {}).setdefault(r.scene_set, {}).setdefault(r.method, []).append(r)
    for _task, sets in out.items():
        for _scene_set, methods in sets.items():
            for method, group in methods.items():
                ttc = np.array([measured.time_to_confidence(r) for r in group])
                confident = ttc[np.isfinite(ttc)]
                curve = np.mean([measured.of(r)["correct"] for r in group], axis=0)
                methods[method] = {
                    "runs": len(group), "never_confident": float(np.mean(~np.isfinite(ttc))),
                    "capped": float(np.mean([measured.of(r)["capped"] for r in group])),
                    "time_to_confidence_median": float(np.median(confident)) if len(confident) else None,
                    **{f"correct_at_{p}": float(curve[curve_index(p)]) for p in ACCURACY_AT},
                    "curve": [round(float(c), 6) for c in curve],
                }
    return {"observer": OBSERVERS[measured.belief.observer], "key": measured.belief.observer,
            "beta": sorted({measured.belief.beta_of(r) for r in measured.records}),
            "threshold": measured.threshold, "curve_fractions": [round(float(f), 6) for f in CURVE], "tasks": out}


def observer_differences(measured: Measured, baseline: str = "dp", methods=COMPARED) -> list[dict]:
    """Each of ``methods`` that ran against ``baseline``, per task and scene set: accuracy at 25/50/75 %,
    the never-confident share, and the time to confidence over the scenes where both became confident."""
    rows = []
    tasks = sorted({r.task for r in measured.records})
    for task in tasks:
        for scene_set in SCENE_SETS:
            group = [r for r in measured.records if r.task == task and r.scene_set == scene_set]
            ran = list(dict.fromkeys(r.method for r in group))
            if baseline not in ran:
                continue
            values = [(f"correct_at_{p}", measured.correct_at(p)) for p in ACCURACY_AT]
            values += [("never_confident", measured.never), ("time_to_confidence", measured.time_to_confidence)]
            for method in (m for m in methods if m in ran and m != baseline):
                for name, value in values:
                    diff = compare_values(group, method, baseline, value, name)
                    if diff.n:  # e.g. no scene where both runs became confident: no difference to state
                        rows.append(diff.row(task=task, scene_set=scene_set))
    return rows


def temperature_rows(records: list[TrajectoryRecord], threshold: float = observers.CONFIDENCE,
                     measured: dict | None = None) -> list[dict]:
    """Each observer under each of its :data:`TEMPERATURES`: per task, scene set and method, the
    never-confident share and the accuracy at 50 %. ``measured`` maps an observer to its
    :class:`Measured` at the default temperature, reused where a temperature equals it."""
    rows = []
    for observer, betas in TEMPERATURES.items():
        done = (measured or {}).get(observer)
        base = done.belief if done else Belief(observer)
        for beta in betas:
            if done and set(done.belief.beta_of(r) for r in done.records) == {beta}:
                m = done
            else:
                m = Measured(records, threshold, belief=base.with_beta(beta))
            for task, sets in observer_summary(m)["tasks"].items():
                for scene_set, methods in sets.items():
                    rows += [{"observer": observer, "beta": beta, "task": task, "scene_set": scene_set, "method": method,
                              "never_confident": v["never_confident"], "correct_at_50": v["correct_at_50"]}
                             for method, v in methods.items()]
    return rows


def temperature_markdown(rows: list[dict]) -> str:
    """One table: a row per task, scene set and method; a column pair per observer and temperature."""
    columns = list(dict.fromkeys((r["observer"], r["beta"]) for r in rows))
    cells: dict = {}
    for r in rows:
        cells.setdefault((r["task"], r["scene_set"], r["method"]), {})[(r["observer"], r["beta"])] = r
    head = " | ".join(f"{o.replace('_', '-')} β={b:g}" for o, b in columns)
    lines = ["Correct at 50 % / never confident, under each temperature (the default is the middle one):", "",
             f"| task | scene set | method | {head} |", "|---|---|---|" + "---|" * len(columns)]
    for (task, scene_set, method), row in cells.items():
        lines.append(f"| {task} | {scene_set} | {method} | " + " | ".join(
            f"{row[c]['correct_at_50']:.2f} / {row[c]['never_confident']:.2f}" if c in row else "–" for c in columns) + " |")
    return "\n".join(lines)


def observer_markdown(summary: dict, differences: list[dict]) -> str:
    """The report's section: one table per task and scene set, then the paired differences."""
    beta = ", ".join(f"{b:g}" for b in summary["beta"])
    lines = [f"Observer: {summary['observer']}, β = {beta} (scale-free), on each stored path cut at the goal and "
             f"resampled to 200 points. Time to confidence: the first fraction of the motion after which "
             f"P(g* | path) stays ≥ {summary['threshold']:g}; runs that never get there are counted apart (never "
             "confident), not averaged in; 'capped by the scene' is the share of runs whose goals are so close that even the "
             "straight path to g* ends with the observer below the threshold. Correct at x %: the "
             "observer's arg-max is the target there (a tie is not).", ""]
    for task, sets in summary["tasks"].items():
        for scene_set in SCENE_SETS:
            if scene_set not in sets:
                continue
            lines += [f"**{task}, {scene_set} scenes**", "",
                      "| method | runs | never confident | capped by the scene | time to confidence (median, confident runs) | "
                      + " | ".join(f"correct at {p} %" for p in ACCURACY_AT) + " |",
                      "|---|---|---|---|---|" + "---|" * len(ACCURACY_AT)]
            for method, m in sets[scene_set].items():
                ttc = "–" if m["time_to_confidence_median"] is None else f"{m['time_to_confidence_median']:.3f}"
                lines.append(f"| {method} | {m['runs']} | {m['never_confident']:.3f} | {m['capped']:.3f} | {ttc} | "
                             + " | ".join(f"{m[f'correct_at_{p}']:.3f}" for p in ACCURACY_AT) + " |")
            lines.append("")
    if differences:
        lines += ["Paired differences against DP (same scenes and noise): mean [95 % bootstrap interval], * where the "
                  f"interval excludes zero from at least {MIN_STARRED} pairs; time to confidence over the scenes where both runs "
                  "became confident (n pairs).", "",
                  "| task | scene set | method | " + " | ".join(m.replace("_", " ") for m in MEASURES) + " |",
                  "|---|---|---|" + "---|" * len(MEASURES)]
        cells: dict = {}
        for d in differences:
            star = "*" if (d["lo"] > 0 or d["hi"] < 0) and d["n"] >= MIN_STARRED else ""
            n = f" (n {d['n']})" if d["metric"] == "time_to_confidence" else ""
            cells.setdefault((d["task"], d["scene_set"], d["a"]), {})[d["metric"]] = \
                f"{d['mean']:+.3f}{star} [{d['lo']:+.3f}, {d['hi']:+.3f}]{n}"
        for (task, scene_set, method), row in cells.items():
            lines.append(f"| {task} | {scene_set} | {method} | " + " | ".join(row.get(m, "–") for m in MEASURES) + " |")
    return "\n".join(lines)


def measure_all(records: list[TrajectoryRecord], threshold: float = observers.CONFIDENCE) -> dict:
    """Every observer's (:data:`OBSERVERS`) :class:`Measured` of the records, at its default temperature."""
    return {observer: Measured(records, threshold, belief=Belief(observer)) for observer in OBSERVERS}


def observer_report(records: list[TrajectoryRecord], threshold: float = observers.CONFIDENCE,
                    measured: dict | None = None) -> dict:
    """Everything the report says about observers, for the records of the random scene sets: per
    observer (:data:`OBSERVERS`) its ``summary`` and ``paired_differences`` against DP, and
    ``temperatures``, every observer under each of its :data:`TEMPERATURES`. ``measured``: the
    records' :func:`measure_all`, when already computed."""
    measured = measured or measure_all(records, threshold)
    out: dict = {observer: {"summary": observer_summary(m), "paired_differences": observer_differences(m)}
                 for observer, m in measured.items()}
    out["temperatures"] = temperature_rows(records, threshold, measured)
    return out


def observer_report_markdown(report: dict, figures: dict) -> str:
    """The report's section: each observer's tables and figure (``figures[observer]``), then the temperatures."""
    lines = []
    for observer in OBSERVERS:
        part = report[observer]
        lines += [f"### {OBSERVERS[observer][0].upper()}{OBSERVERS[observer][1:]}", "",
                  observer_markdown(part["summary"], part["paired_differences"]), "",
                  f"![{OBSERVERS[observer]}: accuracy over the motion]({figures[observer]})", ""]
    lines += ["### Under each temperature", "", temperature_markdown(report["temperatures"]), ""]
    return "\n".join(lines)
