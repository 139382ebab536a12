"""After the stages: merge the tasks' trajectories and write every report file into ``OUT``.

``results.json`` (every record, tagged with its protocol), ``summary_metrics.json``,
Tables 1-2 (random-scene protocol) and 3 (per-layout protocol) as Markdown and LaTeX,
``figure2`` / ``figure2_per_layout``, ``observer_accuracy.png``, ``claims.json`` and ``report.md``. Each is written by
its own function; :func:`write_report` calls them in turn. :func:`rebuild_report` writes every
file but ``results.json`` again from a ``results.json`` alone (no trajectories, no rollouts).

The report carries the failure-aware score T_fa (:data:`FAILURE_AWARE_RULE`), success rates with
95 % intervals, scene-clustered paired intervals for the layout groups, and the metric
sensitivity section (:mod:`scdp.evaluation.sensitivity`): the headline differences with j
normalised over our range and over the training dataset's (``OUT/<task>/demos.zarr``; where it
is absent, the evaluation's random scenes, as the section says).
"""

from __future__ import annotations

import json
from pathlib import Path

from scdp.config import Preset
from scdp.data.dataset import DemoDataset
from scdp.errors import ScdpError
from scdp.evaluation import observation, sensitivity, tables
from scdp.evaluation.figures import figure2, observer_accuracy, save_figure
from scdp.evaluation.normalised import read_ranges
from scdp.evaluation.observer_targets import observer_targets_markdown
from scdp.evaluation.records import TrajectoryRecord, failures_line, load_records
from scdp.io import write_json, write_text
from scdp.keys import AMBIGUOUS, CLEAR, DATASET_NORMALISATION, PER_LAYOUT, RANDOM, SCENE_NORMALISATION, layout_name, layout_number
from scdp.metrics import DEFAULT_BETA
from scdp.observers import CONFIDENCE
from scdp.pipeline import readings
from scdp.pipeline.names import evaluation_key, parse_timed
from scdp.pipeline.stages import protocols_of
from scdp.presets import get_preset
from scdp.scoring import subset_gaps
from scdp.tasks import get_task, task_reference

OBSERVER_FIGURES = {observation.PATH_LENGTH: "observer_accuracy.png",
                    observation.DEMONSTRATION: "observer_accuracy_demonstration.png",
                    observation.VIEWPOINT: "observer_accuracy_viewpoint.png"}
# Every report file but results.json (what rebuild_report may write; figures only when asked).
REPORT_FILES = ("summary_metrics.json", *(f"table{k}{suffix}.{fmt}" for suffix in readings.SUFFIX.values() for k in (1, 2, 3)
                                         for fmt in ("md", "tex")),
                "claims.json", "report.md", "figure2.png", "figure2.pdf", "figure2_per_layout.png", "figure2_per_layout.pdf",
                *OBSERVER_FIGURES.values())
TRAJECTORY_FILES = {RANDOM: "trajectories.json", PER_LAYOUT: f"{PER_LAYOUT}/trajectories.json"}
FIGURES = {RANDOM: "figure2", PER_LAYOUT: "figure2_per_layout"}
# Figure 2 draws these layouts: the first ambiguous and a clear one.
FIGURE_SCENES = {"ambiguous": layout_name(1), "not ambiguous": layout_name(5)}
RANDOM_FIGURE_SCENES = {"ambiguous": AMBIGUOUS, "not ambiguous": CLEAR}  # their first scenes
FAILURE_AWARE_RULE = (
    "T_fa (failure-aware T): a successful run scores its T; a failed run scores min(T, 0). 0 is the score of a path as "
    "poor as the worst of its scene's reference demonstrations on both D̂ and Ê (every reference path has D̂, Ê and so T "
    "in [0, 1]), so a failure is never credited more than that, however high its raw T (a failed detour can score "
    "T > 1); a failed run whose T is already below 0 keeps it. Claims and targets that compare T between methods are "
    "judged on T_fa, raw T beside it; success rates carry their own 95 % Wilson interval, n = distinct scenes.")


def read_stage_times(out: Path) -> dict:
    try:
        return json.loads((out / "stage_times.json").read_text())
    except (OSError, ValueError):
        return {}


def compute_minutes(times: dict, names: list[str]) -> dict:
    """Stage compute per protocol, in minutes: the shared stages count toward ``random``."""
    minutes = {RANDOM: 0.0, PER_LAYOUT: 0.0}
    for key, seconds in times.items():
        task, stage = parse_timed(key)
        if task in names:
            minutes[stage.protocol] += seconds / 60
    return {k: round(v, 1) for k, v in minutes.items()}


def collect_records(out: Path, names: list[str], protocols: list[str]) -> list[TrajectoryRecord]:
    """Every task's trajectories of every protocol that ran, tagged with the protocol."""
    records = []
    for protocol in protocols:
        for name in names:
            for r in load_records(out / name / TRAJECTORY_FILES[protocol]):
                r.protocol = protocol
                records.append(r)
    return records


def write_tables(out: Path, summary: dict, normalisation: str = SCENE_NORMALISATION) -> None:
    """Tables 1-2 (random-scene protocol) and 3 (per-layout) of one reading: ``table1.md`` per scene,
    ``table1_dataset.md`` over the training data, and so on."""
    suffix, reading = readings.SUFFIX[normalisation], readings.CAPTIONS[normalisation]
    if RANDOM in summary:
        for fmt in ("md", "tex"):
            write_text(out / f"table1{suffix}.{fmt}", tables.table1(summary[RANDOM], fmt, reading))
            write_text(out / f"table2{suffix}.{fmt}", tables.table2(summary[RANDOM], fmt, reading))
    if PER_LAYOUT in summary:
        for fmt in ("md", "tex"):
            write_text(out / f"table3{suffix}.{fmt}", tables.table3(summary, fmt, reading))


def write_figures(out: Path, records: list[TrajectoryRecord], names: list[str], protocols: list[str],
                  observed: dict | None = None) -> None:
    for protocol in protocols:
        mine = [r for r in records if r.protocol == protocol]
        scenes = {n: FIGURE_SCENES if any(r.task == n and layout_number(r.scene_set) is not None for r in mine)
                  else RANDOM_FIGURE_SCENES for n in names}  # runs with more than two goals have no layouts
        fig = figure2(mine, scenes)
        for suffix in (".png", ".pdf"):
            save_figure(fig, (out / FIGURES[protocol]).with_suffix(suffix))
    for observer, name in OBSERVER_FIGURES.items():
        if observed and observed[observer]["summary"]["tasks"]:
            save_figure(observer_accuracy(observed[observer]["summary"]), out / name)


def observer_measures(records: list[TrajectoryRecord], confidence: float = CONFIDENCE) -> tuple[dict, dict]:
    """The observer report of the random-scene models (:func:`scdp.evaluation.observation.observer_report`),
    confident from ``confidence`` on, and the one reading of every path by each observer it rests on
    (which the adaptivity and observer targets of either normalisation read again)."""
    random = [r for r in records if r.protocol == RANDOM]
    measured = observation.measure_all(random, confidence)
    return observation.observer_report(random, confidence, measured), measured


def failure_aware_note(records: list[TrajectoryRecord]) -> str:
    """The T_fa rule, with how often it bites in these records."""
    failed = [r for r in records if not r.success]
    below = sorted({r.method for r in records if r.success and r.metrics["transparency"] < 0})
    n_below = sum(r.success and r.metrics["transparency"] < 0 for r in records)
    ended = failures_line(records)  # rollouts ended early (left the bounds): "" when none
    return (f"{FAILURE_AWARE_RULE} Here {len(failed)} of {len(records)} runs failed ({sum(r.metrics['transparency'] > 0 for r in failed)} "
            f"of them with T > 0, up to {max((r.metrics['transparency'] for r in failed), default=0.0):.2f}); "
            f"{n_below} successful runs score T < 0 ({', '.join(below) or 'none'}).") + (f" {ended}" if ended else "")


def sensitivity_ranges(out: Path, records: list[TrajectoryRecord]) -> tuple[dict, dict]:
    """Each task's alternative j range and its source: the training dataset (``OUT/<task>/demos.zarr``)
    when present, otherwise the task's random evaluation scenes."""
    ranges, sources = {}, {}
    for task in sorted({r.task for r in records}):
        demos = out / task / "demos.zarr"
        if demos.exists():
            ranges[task], sources[task] = sensitivity.dataset_range(DemoDataset.load(demos)), "training dataset"
        else:
            ranges[task] = sensitivity.evaluation_range(records, task)
            sources[task] = "evaluation scenes (training dataset not present)"
    return ranges, sources


def metric_sensitivity(out: Path, records: list[TrajectoryRecord]) -> dict:
    """The headline differences under both j normalisations, on the random-scene protocol's two sets."""
    random = [r for r in records if r.protocol == RANDOM and r.scene_set in tables.SETS]
    if not random:
        return {}
    ranges, sources = sensitivity_ranges(out, random)
    return sensitivity.sensitivity(random, ranges, sources)


def subset_gap_of(out: Path, names: list[str], preset: Preset) -> dict:
    """Each task's style-subset gap of its training data in ambiguous scenes (where its demos are in ``out``)."""
    gaps = {}
    for name in names:
        demos = out / name / "demos.zarr"
        if demos.exists():
            gap = subset_gaps(DemoDataset.load(demos), preset.data.style_fraction)
            gaps[name] = gap.get("ambiguous", gap["all"])
    return gaps


def report_markdown(views: dict, preset: Preset, command: str, wall: float, minutes: dict, ranges: dict, fa_note: str = "",
                    sensitivity_result: dict | None = None, observed: dict | None = None, executor: str = "") -> str:
    """report.md: the verdicts under both readings first, then every section per scene, then the
    reading over the training data (``views``: :func:`scdp.pipeline.readings.judge`)."""
    scene = views[SCENE_NORMALISATION]
    summary, shown = scene.summary, readings.render(scene)
    lines = [f"# SCDP reproduction ({preset.name} preset)", "", f"Command: `{command}`", "",
             f"Compute time of all stages: {wall} s ({wall / 60:.1f} min): random-scene protocol {minutes[RANDOM]} min "
             f"(with the shared ambiguity and encoder stages), per-layout protocol {minutes[PER_LAYOUT]} min. "
             f"Observer temperature β = {DEFAULT_BETA:g} (scale-free).", ""]
    if executor:
        lines += [f"Run by the {executor}.", ""]
    if preset.overrides:
        lines += [f"Overrides: `{' '.join(preset.overrides)}`", ""]
    if preset.data.goals != 2:
        lines += [f"**{preset.data.goals} goals per scene** (the target and {preset.data.goals - 1} distractors; "
                  "docs/goals.md defines D, j and ambiguity for them). The paper's columns hold its two-goal numbers, "
                  "for scale only; the six two-goal layouts are not evaluated.", ""]
    if DATASET_NORMALISATION in views:
        lines += ["## Every verdict under both normalisations", "", readings.verdicts_markdown(readings.verdicts(views)), ""]
    else:
        lines += ["The reading over the training data is not shown: the demos of "
                  f"{', '.join(sorted({readings.range_key(r) for r in scene.records} - set(ranges)))} are not at hand.", ""]
    if fa_note:
        lines += [fa_note, ""]
    if shown.random_tables:
        lines += ["## Models trained on random scenes (D̂, Ê per scene)", "", shown.random_tables, "",
                  "![Figure 2](figure2.png)", ""]
    if shown.layout_table:
        lines += ["## The authors' per-layout protocol (D̂, Ê per scene)", "",
                  f"One model set per fixed layout, trained on {preset.layouts.demos} demos of that layout; the random-scene "
                  "models are evaluated on the same layouts. Ambiguous: layouts 1-3; clear: 4-6.", "",
                  shown.layout_table, "", "![Figure 2, per-layout models](figure2_per_layout.png)", ""]
    if shown.paired:
        lines += ["## Paired differences, per scene (same scenes, same noise; 95 % bootstrap intervals, * = excludes zero)", "",
                  "The bootstrap resamples scenes: where a scene has several pairs (a layout's repeats of one target), "
                  "they are drawn together. A layout group holds only 6 scenes (3 layouts × 2 targets), so its intervals "
                  "are rough.", "", shown.paired, ""]
    if sensitivity_result:
        lines += ["## Metric sensitivity: the range of j alone (D̂, Ê per scene)", "",
                  sensitivity.sensitivity_markdown(sensitivity_result), ""]
    if observed and observed[observation.PATH_LENGTH]["summary"]["tasks"]:
        lines += ["## What an observer reads (random-scene models; the same under either normalisation)", "",
                  observation.observer_report_markdown(observed, OBSERVER_FIGURES)]
    if shown.adaptivity:
        lines += ["## Adaptivity, measured directly (random-scene models; D̂, Ê per scene)", "", shown.adaptivity, ""]
    if scene.observer_targets:
        lines += ["## Observer targets (issue 36; paired 95 % intervals; D̂, Ê per scene)", "",
                  "What the path-length observer reads at 50 % of the motion in ambiguous scenes, and the share of each "
                  "forced style's advantage SCDP keeps (the section above); the rule and margins are those of "
                  "`scdp.evaluation.observer_targets`.", "", observer_targets_markdown(scene.observer_targets), ""]
    if shown.targets:
        lines += ["## Style-effect targets (issue 9; paired 95 % intervals; D̂, Ê per scene)", "", shown.targets, ""]
    lines += ["## The paper's claims on our data (D̂, Ê per scene)", "", shown.claims]
    if DATASET_NORMALISATION in views:
        lines += ["", "## Read over the training data (the paper's wording)", "",
                  readings.dataset_markdown(views[DATASET_NORMALISATION], ranges)]
    for protocol in summary:
        lines += ["", f"### All metrics, {tables.PROTOCOL_NAMES[protocol]} (D̂, Ê per scene)", "",
                  tables.metrics_table(summary[protocol], DEFAULT_BETA)]
    return "\n".join(lines) + "\n"


def write_outputs(out: Path, records: list[TrajectoryRecord], names: list[str], protocols: list[str], preset: Preset,
                  command: str, wall: float, minutes: dict, *, figures: bool = True, confidence: float = CONFIDENCE,
                  ranges: dict | None = None, executor: str = "") -> None:
    """Every report file but results.json, from the records, under each normalisation (``ranges``: the
    training data's, :func:`scdp.pipeline.readings.dataset_ranges`): summaries, tables, figures
    (optional), claims.json (the per-scene claims, targets, paired differences, adaptivity and observer
    targets at its top level, the same over the training data under ``dataset``, and ``verdicts``
    setting both side by side; the T_fa rule, metric sensitivity, the observer measures with
    ``confidence`` as the observer's threshold) and report.md."""
    ranges = ranges or {}
    observed, measured = observer_measures(records, confidence)
    views = readings.judge(records, protocols, ranges, measured, subset_gap_of(out, names, preset))
    scene = views[SCENE_NORMALISATION]
    write_json(out / "summary_metrics.json", scene.summary)
    for name, view in views.items():
        write_tables(out, view.summary, name)
    if figures:
        write_figures(out, records, names, protocols, observed)
    sens = metric_sensitivity(out, records)
    dataset = {DATASET_NORMALISATION: views[DATASET_NORMALISATION].to_dict()} if DATASET_NORMALISATION in views else {}
    write_json(out / "claims.json", {**scene.to_dict(), "normalisation": SCENE_NORMALISATION,
                                     "verdicts": readings.verdicts(views) if dataset else [],
                                     "normalisation_ranges": {k: v.to_dict() for k, v in sorted(ranges.items())}, **dataset,
                                     "failure_aware_rule": FAILURE_AWARE_RULE, "metric_sensitivity": sens,
                                     "observers": observed})
    write_text(out / "report.md", report_markdown(views, preset, command, wall, minutes, ranges, failure_aware_note(records),
                                                  sens, observed, executor))


def write_report(out: Path, names: list[str], preset: Preset, command: str, protocol: str = RANDOM,
                 executor: str = "") -> dict:
    """Merge the tasks' trajectories into results.json; write the tables, figures, claims and report.md.
    ``executor``: what ran the stages, in words (:meth:`scdp.pipeline.executor.LocalExecutor.describe`)."""
    protocols = protocols_of(protocol)
    records = collect_records(out, names, protocols)
    times = read_stage_times(out)
    wall = round(sum(v for k, v in times.items() if parse_timed(k)[0] in names), 2)
    minutes = compute_minutes(times, names)
    # each evaluation's settings and inputs beside the records, so that reproduce can restore a
    # trajectories file from results.json (scdp.pipeline.evaluate.EvaluationStage)
    evaluations = {evaluation_key(name, p): {k: v for k, v in json.loads((out / name / TRAJECTORY_FILES[p]).read_text()).items()
                                   if k != "records"} for p in protocols for name in names}
    meta = {"command": command, "preset": preset.name, "overrides": list(preset.overrides or ()), "protocols": protocols,
            "wall_seconds": wall, "compute_minutes": minutes, "evaluations": evaluations, "executor": executor}
    ranges = readings.dataset_ranges(out, records)
    meta["normalisation_ranges"] = {k: v.to_dict() for k, v in sorted(ranges.items())}
    references = {name: task_reference(name) for name in names}
    if any(ref != name for name, ref in references.items()):  # a task of your own: how `scdp report` finds it again
        meta["task_references"] = references
    write_json(out / "results.json", {**meta, "trajectories": [r.to_dict() for r in records]}, compact=True)
    write_outputs(out, records, names, protocols, preset, command, wall, minutes, ranges=ranges, executor=executor)
    return {"results": str(out / "results.json"), "report": str(out / "report.md")}


def rebuild_report(results: Path, out: Path, *, figures: bool = False, confidence: float = CONFIDENCE) -> dict:
    """Write every report file but results.json into ``out`` again, from a ``results.json`` alone.

    Nothing is rerun: the records, command, preset, overrides and compute times come from the
    file. The style-subset gaps and the training dataset's j range need ``out/<task>/demos.zarr``;
    without it the targets leave the gap out and the sensitivity section uses the evaluation scenes.
    """
    results, out = Path(results), Path(out)
    try:
        meta = json.loads(results.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ScdpError("results", f"{results} is not a readable results.json ({exc})") from None
    if not isinstance(meta, dict) or not isinstance(meta.get("trajectories"), list) or not meta["trajectories"]:
        raise ScdpError("results", f"{results} holds no trajectories (a results.json written by scdp reproduce)")
    for reference in (meta.get("task_references") or {}).values():
        get_task(reference)  # a task of your own, loaded (and checked) before its records are read
    records = load_records(results)
    protocols = list(meta.get("protocols") or [RANDOM])
    for r in records:
        r.protocol = r.protocol or protocols[0]
    names = sorted({r.task for r in records})
    preset = get_preset(meta.get("preset", "cpu"), meta.get("overrides") or ())
    minutes = {RANDOM: 0.0, PER_LAYOUT: 0.0, **(meta.get("compute_minutes") or {})}
    ranges = readings.dataset_ranges(out, records, read_ranges(meta.get("normalisation_ranges")))
    write_outputs(out, records, names, protocols, preset, meta.get("command", ""), meta.get("wall_seconds", 0.0), minutes,
                  figures=figures, confidence=confidence, ranges=ranges, executor=meta.get("executor", ""))
    return {"report": str(out / "report.md"), "claims": str(out / "claims.json")}
