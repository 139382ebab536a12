"""``scdp study analyze``: from the stored responses to curves, paired comparisons and a report.

Per response (a confirmed main trial), with t the fraction of the motion shown (every motion plays at
one speed, the robot's, so its duration follows its length: ``duration_s`` is reported per method as a
covariate, and accuracy is read both by fraction and by seconds of motion, ``correct_at_1s`` ...):

* ``correct(t)``: whether the goal picked last at or before t is the target (no pick yet: not correct);
* ``final``: whether the confirmed goal is the target;
* ``t_kept``: the t of the pick from which the participant stayed on the target to the end (1.0
  when the confirmed goal is wrong: a fixed penalty, so every response counts);
* ``changes``: how often the pick moved to another goal.

Who counts: the participants :mod:`scdp.study.screening` keeps by the study's own rules (fixed in
``study.json`` before data collection); every other one is listed with its reasons, never
analysed. t is the server's: the fraction of the motion its clock had reached when the pick
arrived, which a page cannot move earlier. Uncertainty: participants and scenes are *crossed* (a Latin square shows
each participant every method, each on other scenes), so both are random. Every interval is a
two-way cluster bootstrap that resamples participants and scenes independently and weights each
response by how often both were drawn (Owen's pigeonhole bootstrap), percentile 95 %. A
mixed-effects logistic model would say the same with more assumptions (its random-effect
distribution, and convergence with a few dozen people); the bootstrap needs only that participants
and scenes are exchangeable. A paired difference A - B is computed within each resample, so the
pairing by participant and scene is kept.

The interaction asks whether a method's advantage depends on the scene: (A - B on ambiguous
scenes) - (A - B on clear scenes), in the same resamples.

Beside each human curve: the project's two observers (:mod:`scdp.observers`, the path-length
observer at the legibility metric's beta and the demonstration observer) on the very paths shown.
"""

from __future__ import annotations

import csv
import io
from datetime import datetime, timezone
from itertools import combinations

import numpy as np
from matplotlib.figure import Figure

from scdp.evaluation.observation import OBSERVERS
from scdp.evaluation.resampling import crossed_weights, percentile_interval, weighted_means
from scdp.study.covariates import position_checks, rating_summary
from scdp.study.design import API_STUDY_ID
from scdp.study.quantities import AT, AT_S, QUANTITIES
from scdp.study.readable import REACTION_S, observer_correct, pick_at
from scdp.study.record import ANALYSED, MAIN, SETS, Study
from scdp.study.screening import participant_table

GRID = np.linspace(0.0, 1.0, 41)  # fractions of the motion the curves are read at
OBSERVER_LINES = {"path_length": "--", "demonstration": ":", "viewpoint": "-."}  # line styles in the figure
SECONDS_STEP = 0.25  # the curves in seconds are read every this many seconds of motion
SAMPLES = 2000
SMALL_SAMPLE = 20  # fewer analysed participants than this: the report warns that its intervals are rough
CSV_FIELDS = ("pid", "number", "row", "simulated", "analysed", "trial", "kind", "stimulus", "method", "scene_set",
              "scene_index", "mirror", "goal_order", "target", "choice", "target_position", "choice_position",
              "instructed", "final", "correct", "t_kept", "changes", "confidence", "duration_s", "first_pick_t",
              "first_pick_s", "served_utc",
              "played_utc", "confirmed_utc", "loads", "replays", "hidden", "blurs", "refused", "events")


def correct_curve(events: list[dict], target: int, grid=GRID) -> np.ndarray:
    """Whether the latest pick at or before each t of ``grid`` is ``target``: (len(grid),) of 0/1."""
    out = np.zeros(len(grid))
    for e in events:  # in order: a later pick overwrites from its t on
        out[np.asarray(grid) >= e["t"]] = float(e["goal"] == target)
    return out


def correct_at_seconds(events: list[dict], target: int, seconds: float) -> float:
    """Whether the latest pick at or before ``seconds`` of the motion (the server's) is ``target``."""
    return float(pick_at(events, seconds, "s") == target)


def seconds_grid(study: Study) -> np.ndarray:
    """Seconds of motion the curves in seconds are read at: every ``SECONDS_STEP`` up to the longest main motion."""
    longest = max(study.motion_s(sid) for sid, stim in study.stimuli.items() if stim.kind == MAIN)
    return np.arange(0.0, longest + SECONDS_STEP, SECONDS_STEP)


def kept_time(events: list[dict], target: int) -> float:
    """The t from which the picks stay on ``target`` to the end; 1.0 when the last pick is not it."""
    if events[-1]["goal"] != target:
        return 1.0
    t = events[-1]["t"]
    for e in reversed(events):
        if e["goal"] != target:
            break
        t = e["t"]
    return float(t)


def changes_of_mind(events: list[dict]) -> int:
    return int(sum(a["goal"] != b["goal"] for a, b in zip(events, events[1:])))


def _utc(seconds: float) -> str:
    return datetime.fromtimestamp(seconds, tz=timezone.utc).isoformat(timespec="milliseconds")


def response_table(study: Study, rows: list[dict], analysed: set, simulated: set) -> list[dict]:
    """One dict per stored response with its derived quantities; main responses of the ``analysed``
    participants are the analysed ones, and the ``simulated`` participants' are marked so."""
    out, grid_s = [], seconds_grid(study)
    for r in rows:
        stim, length = study.stimuli[r["stimulus"]], study.motion_s(r["stimulus"])
        events = [{**e, "s": e.get("s", e["t"] * length)} for e in r["events"]]
        curve = correct_curve(events, stim.target)
        curve_s = np.array([correct_at_seconds(events, stim.target, x) for x in grid_s])
        out.append({"pid": r["pid"], "number": r["number"], "row": r["row"], "simulated": r["pid"] in simulated,
                    "analysed": r["kind"] in ANALYSED and r["pid"] in analysed,
                    "trial": r["trial"], "kind": r["kind"], "stimulus": r["stimulus"], "method": stim.method,
                    "scene_set": stim.scene_set, "scene_index": stim.scene_index, "mirror": bool(r["mirror"]),
                    "goal_order": " ".join(map(str, r["goal_order"])), "target": stim.target, "choice": r["choice"],
                    "target_position": r["target_position"], "choice_position": r["choice_position"],
                    "instructed": r["instructed"], "correct": bool(r["correct"]),  # instructed: followed the instruction
                    "final": float(r["choice"] == stim.target), "t_kept": kept_time(events, stim.target),
                    "confidence": float(r["confidence"]), "hidden": r["hidden"], "blurs": r["blurs"],
                    "refused": r["refused"],
                    "changes": changes_of_mind(events), "first_pick_t": events[0]["t"], "first_pick_s": events[0]["s"],
                    "duration_s": length, **{f"correct_at_{x:g}s": correct_at_seconds(events, stim.target, x) for x in AT_S},
                    "served_utc": _utc(r["served"]), "played_utc": _utc(r["played"]),
                    "confirmed_utc": _utc(r["confirmed"]), "loads": r["loads"], "replays": r["replays"],
                    "events": events, "curve": curve, "curve_s": curve_s,
                    **{f"correct_at_{round(100 * f)}": float(np.interp(f, GRID, curve)) for f in AT}})
    return out


def responses_csv(table: list[dict]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=CSV_FIELDS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for r in table:
        writer.writerow({**r, "events": " ".join(f"{e['t']:.4f}/{e['client_t']:.4f}:{e['goal']}" for e in r["events"])})
    return buffer.getvalue()


def observer_curves(study: Study, stimuli: list[str], grid=GRID, *, seconds=None) -> dict:
    """Every observer of the project on the shown paths (:func:`scdp.study.readable.observer_correct`), by
    fraction (``grid``) or by seconds after the reaction delay (``seconds``): {observer: (G,) mean correct}."""
    ids, counts = np.unique(np.asarray(stimuli, dtype=str), return_counts=True)  # each stimulus read once, weighted
    reads = observer_correct(study, ids.tolist(), None if seconds is not None else grid, seconds=seconds)
    return {k: counts @ v / counts.sum() if len(v) else np.full(v.shape[1], np.nan) for k, v in reads.items()}


def analyse(study: Study, participants: list[dict], rows: list[dict], ratings: list[dict] = (), *,
            samples: int = SAMPLES, seed: int = 0) -> tuple[dict, list[dict], list[dict]]:
    """The summary (who, per method and scene set, paired comparisons, the interaction, observers,
    the button-position checks, the ratings), the response table and the participant table."""
    people = participant_table(study, participants, rows)
    analysed = {p["pid"] for p in people if p["analysed"]}
    simulated = {p["pid"] for p in people if p["simulated"]}
    table = response_table(study, rows, analysed, simulated)
    used = [r for r in table if r["analysed"]]
    methods = list(study.config.methods)
    summary = {"task": study.task, "methods": methods, "participants": len(people),
               "people": len(people) - len(simulated), "simulated_participants": len(simulated),
               "simulated_through_api": sum(p["simulated"] and p["study_id"] == API_STUDY_ID for p in people),
               "data": ("simulated" if simulated and len(simulated) == len(people) else
                        "mixed" if simulated else "people"),
               "analysed_participants": len(analysed), "screening": study.config.screening.to_dict(),
               "excluded": {p["pid"]: p["reasons"] for p in people if not p["analysed"]},
               "small_sample": len(analysed) < SMALL_SAMPLE,
               "responses": len(used), "grid": GRID.tolist(), "grid_s": seconds_grid(study).tolist(),
               "reaction_s": REACTION_S, "bootstrap": {"samples": samples, "seed": seed,
               "kind": "two-way cluster (participants x scenes) percentile"}, "sets": {}, "interaction": [],
               "ratings": rating_summary(list(ratings), analysed, methods, samples=samples, seed=seed)}
    if not used:
        return summary, table, people
    participants_of = np.array([r["pid"] for r in used])
    scenes = np.array([f"{r['scene_set']}/{r['scene_index']}" for r in used])
    weights = crossed_weights(participants_of, scenes, samples, seed)
    summary["position"] = position_checks(used, weights, study.goals, methods)
    values = {q: np.array([r[q] for r in used], dtype=np.float64) for q in QUANTITIES}
    curves = {"": np.stack([r["curve"] for r in used]), "_s": np.stack([r["curve_s"] for r in used])}
    is_method = {m: np.array([r["method"] == m for r in used]) for m in methods}
    diffs = {}  # (scene set, a, b, quantity) -> the paired difference in every resample
    for scene_set in SETS:
        in_set = np.array([r["scene_set"] == scene_set for r in used])
        block = {"methods": {}, "paired": [], "observer_paired": []}
        for m in methods:
            mask = in_set & is_method[m]
            if mask.any():
                shown = [r["stimulus"] for r in used if r["method"] == m and r["scene_set"] == scene_set]
                block["methods"][m] = _method_block(study, shown, weights, values, curves, mask)
        for a, b in combinations([m for m in methods if m in block["methods"]], 2):
            block["observer_paired"] += _observer_differences(a, b, block["methods"][a], block["methods"][b])
            ma, mb = in_set & is_method[a], in_set & is_method[b]
            for q in QUANTITIES:
                diff = weighted_means(weights, values[q], ma) - weighted_means(weights, values[q], mb)
                diffs[scene_set, a, b, q] = (float(values[q][ma].mean() - values[q][mb].mean()), diff)
                block["paired"].append(_claim(a, b, q, *diffs[scene_set, a, b, q]))
        summary["sets"][scene_set] = block
    for a, b in combinations(methods, 2):
        for q in QUANTITIES:
            if (SETS[0], a, b, q) in diffs and (SETS[1], a, b, q) in diffs:
                (m0, d0), (m1, d1) = diffs[SETS[0], a, b, q], diffs[SETS[1], a, b, q]
                summary["interaction"].append(_claim(a, b, q, m0 - m1, d0 - d1))
    return summary, table, people


def _method_block(study: Study, shown: list[str], weights, values: dict, curves: dict, mask) -> dict:
    """One method on one scene set: every quantity's mean and interval, the curves by fraction and by seconds
    with their bands, and every observer's on the very stimuli shown (weighted as the responses are), by
    fraction and by seconds after the reaction delay, and at the points the quantities read."""
    grid_s = seconds_grid(study)
    out = {"responses": int(mask.sum()),
           **{q: {"mean": float(values[q][mask].mean()), "ci": percentile_interval(weighted_means(weights, values[q], mask))}
              for q in QUANTITIES}}
    for suffix, curve in curves.items():
        draws = weighted_means(weights, curve, mask)
        out["curve" + suffix] = curve[mask].mean(axis=0).tolist()
        out["curve" + suffix + "_band"] = [np.nanpercentile(draws, 2.5, axis=0).tolist(),
                                           np.nanpercentile(draws, 97.5, axis=0).tolist()]
    obs = observer_curves(study, shown)
    out["observers"] = {k: v.tolist() for k, v in obs.items()}
    out["observers_s"] = {k: v.tolist() for k, v in observer_curves(study, shown, seconds=grid_s).items()}
    at_f, at_s = observer_curves(study, shown, AT), observer_curves(study, shown, seconds=AT_S)
    out["observers_at"] = {k: {**{f"correct_at_{round(100 * f)}": float(v) for f, v in zip(AT, at_f[k])},
                               **{f"correct_at_{x:g}s": float(v) for x, v in zip(AT_S, at_s[k])}} for k in at_f}
    out["gap_to_path_length_observer"] = float(np.mean(np.abs(curves[""][mask].mean(axis=0) - obs["path_length"])))
    return out


def _observer_differences(a: str, b: str, block_a: dict, block_b: dict) -> list[dict]:
    """Each observer's a - b at the fractions and seconds the people's quantities read (on the stimuli shown)."""
    return [{"a": a, "b": b, "observer": name, "quantity": q, "difference": block_a["observers_at"][name][q] - v}
            for name, reads in block_b["observers_at"].items() for q, v in reads.items()]


def _claim(a: str, b: str, q: str, mean: float, draws: np.ndarray) -> dict:
    lo, hi = percentile_interval(draws)
    return {"a": a, "b": b, "quantity": q, "mean": mean, "ci": [lo, hi], "excludes_zero": bool(lo > 0 or hi < 0)}


def accuracy_figure(summary: dict):
    """Share of correct predictions over the motion, per scene set, by fraction of the motion (top) and by
    seconds of it (bottom): people (band: 95 % crossed bootstrap) and every observer of the project on the same
    paths (dashed, dotted, dash-dotted; in seconds after the reaction delay ``summary["reaction_s"]``)."""
    sets = [s for s in SETS if summary["sets"].get(s, {}).get("methods")]
    fig = Figure(figsize=(5.2 * max(1, len(sets)), 7.2))
    axes = fig.subplots(2, max(1, len(sets)), squeeze=False)
    who = "simulated participants" if summary["data"] == "simulated" else "participants"
    rows = (("", "grid", "fraction of the motion shown"),
            ("_s", "grid_s", f"seconds of motion (observers {summary.get('reaction_s', 0):g} s behind)"))
    for row, (suffix, grid, label) in enumerate(rows):
        for ax, scene_set in zip(axes[row], sets):
            for i, (m, v) in enumerate(summary["sets"][scene_set]["methods"].items()):
                colour = f"C{i}"
                ax.plot(summary[grid], v["curve" + suffix], color=colour, lw=2, label=f"{m} ({who})")
                ax.fill_between(summary[grid], *v["curve" + suffix + "_band"], color=colour, alpha=0.18, lw=0)
                for name, curve in v["observers" + suffix].items():
                    ax.plot(summary[grid], curve, color=colour, ls=OBSERVER_LINES.get(name, "-"), lw=1.2,
                            label=f"{m} ({OBSERVERS.get(name, name).split(' (')[0]})")
            ax.set(title=f"{summary['task']}: {scene_set} scenes", xlabel=label, ylim=(-0.02, 1.02))
            ax.grid(alpha=0.3)
        axes[row][0].set_ylabel("share predicting the true goal")
    axes[0][-1].legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    return fig
