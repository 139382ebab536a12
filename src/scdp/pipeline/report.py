"""After the stages: merge the tasks' trajectories and write every report file into ``OUT``.

``results.json`` (every record, tagged with its protocol), ``summary_metrics.json``,
Tables 1-2 (random-scene protocol) and 3 (per-layout protocol) as Markdown and LaTeX,
``figure2`` / ``figure2_per_layout``, ``claims.json`` and ``report.md``. Each is written by
its own function; :func:`write_report` calls them in turn.
"""

from __future__ import annotations

import json
from pathlib import Path

from scdp.config import Preset
from scdp.data.dataset import DemoDataset
from scdp.data.subsets import subset_gaps
from scdp.evaluation import claims, statistics, tables, targets
from scdp.evaluation.figures import figure2, save_figure
from scdp.evaluation.records import TrajectoryRecord, load_records
from scdp.io import write_json, write_text
from scdp.keys import PER_LAYOUT, RANDOM
from scdp.metrics import DEFAULT_BETA
from scdp.pipeline.stages import protocols_of

TRAJECTORY_FILES = {RANDOM: "trajectories.json", PER_LAYOUT: f"{PER_LAYOUT}/trajectories.json"}
FIGURES = {RANDOM: "figure2", PER_LAYOUT: "figure2_per_layout"}
# Figure 2 draws these layouts: the first ambiguous and a clear one.
FIGURE_SCENES = {"ambiguous": "layout_1", "not ambiguous": "layout_5"}


def read_stage_times(out: Path) -> dict:
    try:
        return json.loads((out / "stage_times.json").read_text())
    except (OSError, ValueError):
        return {}


def compute_minutes(times: dict, names: list[str]) -> dict:
    """Stage compute per protocol, in minutes: the shared stages count toward ``random``."""
    minutes = {RANDOM: 0.0, PER_LAYOUT: 0.0}
    for key, seconds in times.items():
        if key.split("/")[0] in names:
            minutes[PER_LAYOUT if f"/{PER_LAYOUT}/" in key else RANDOM] += seconds / 60
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


def write_tables(out: Path, summary: dict) -> None:
    if RANDOM in summary:
        for fmt in ("md", "tex"):
            write_text(out / f"table1.{fmt}", tables.table1(summary[RANDOM], fmt))
            write_text(out / f"table2.{fmt}", tables.table2(summary[RANDOM], fmt))
    if PER_LAYOUT in summary:
        for fmt in ("md", "tex"):
            write_text(out / f"table3.{fmt}", tables.table3(summary, fmt))


def write_figures(out: Path, records: list[TrajectoryRecord], names: list[str], protocols: list[str]) -> None:
    for protocol in protocols:
        fig = figure2([r for r in records if r.protocol == protocol], {n: FIGURE_SCENES for n in names})
        for suffix in (".png", ".pdf"):
            save_figure(fig, (out / FIGURES[protocol]).with_suffix(suffix))


def judge_claims(summary: dict, records: list[TrajectoryRecord]) -> list[dict]:
    """The paper's claims on each protocol that ran (per-layout: layouts 1-3 vs 4-6)."""
    of = {p: [r for r in records if r.protocol == p] for p in summary}
    judged = claims.claims(summary[RANDOM], records=of[RANDOM]) if RANDOM in summary else []
    if PER_LAYOUT in summary:
        judged += claims.claims(summary[PER_LAYOUT], tables.LAYOUT_GROUPS, protocol=PER_LAYOUT)
    return judged


def comparisons(records: list[TrajectoryRecord]) -> list[dict]:
    """Paired differences (SCDP − DP, − LD, − Dataset) on the random-scene protocol's two sets."""
    return statistics.paired_comparisons([r for r in records if r.protocol == RANDOM], tables.SETS)


def style_targets(out: Path, names: list[str], records: list[TrajectoryRecord], preset: Preset) -> list[dict]:
    """The style-effect targets on the random-scene records, with each task's style-subset gap."""
    gaps = {}
    for name in names:
        demos = out / name / "demos.zarr"
        if demos.exists():
            gap = subset_gaps(DemoDataset.load(demos), preset.data.style_fraction)
            gaps[name] = gap.get("ambiguous", gap["all"])
    return targets.targets([r for r in records if r.protocol == RANDOM], gaps)


def report_markdown(summary: dict, judged: list[dict], paired: list[dict], preset: Preset, command: str, wall: float,
                    minutes: dict, goals: list[dict] = ()) -> str:
    lines = [f"# SCDP reproduction ({preset.name} preset)", "", f"Command: `{command}`", "",
             f"Compute time of all stages: {wall} s ({wall / 60:.1f} min): random-scene protocol {minutes[RANDOM]} min "
             f"(with the shared ambiguity and encoder stages), per-layout protocol {minutes[PER_LAYOUT]} min. "
             f"Observer temperature β = {DEFAULT_BETA:g} (scale-free).", ""]
    if preset.overrides:
        lines += [f"Overrides: `{' '.join(preset.overrides)}`", ""]
    if RANDOM in summary:
        lines += ["## Models trained on random scenes", "", tables.table1(summary[RANDOM]), "", tables.table2(summary[RANDOM]), "",
                  "![Figure 2](figure2.png)", ""]
    if PER_LAYOUT in summary:
        lines += ["## The authors' per-layout protocol", "",
                  f"One model set per fixed layout, trained on {preset.layouts.demos} demos of that layout; the random-scene "
                  "models are evaluated on the same layouts. Ambiguous: layouts 1-3; clear: 4-6.", "",
                  tables.table3(summary), "", "![Figure 2, per-layout models](figure2_per_layout.png)", ""]
    if paired:
        lines += ["## Paired differences (same scenes, same noise; 95 % bootstrap intervals, * = excludes zero)", "",
                  statistics.comparisons_markdown(paired), ""]
    if goals:
        lines += ["## Style-effect targets (issue 9; paired 95 % intervals)", "", targets.targets_markdown(goals), ""]
    lines += ["## The paper's claims on our data", "", "| task | models | claim | holds | numbers |", "|---|---|---|---|---|"]
    lines += [f"| {c['task']} | {tables.PROTOCOL_NAMES[c['protocol']]} | {c['claim']} | {'yes' if c['holds'] else '**no**'} | "
              f"`{json.dumps(c['numbers'])}` |" for c in judged]
    for protocol in summary:
        lines += ["", f"### All metrics, {tables.PROTOCOL_NAMES[protocol]}", "", tables.metrics_table(summary[protocol], DEFAULT_BETA)]
    return "\n".join(lines) + "\n"


def write_report(out: Path, names: list[str], preset: Preset, command: str, protocol: str = RANDOM) -> dict:
    """Merge the tasks' trajectories into results.json; write the tables, figures, claims and report.md."""
    protocols = protocols_of(protocol)
    records = collect_records(out, names, protocols)
    times = read_stage_times(out)
    wall = round(sum(v for k, v in times.items() if k.split("/")[0] in names), 2)
    minutes = compute_minutes(times, names)
    write_json(out / "results.json", {"command": command, "preset": preset.name, "overrides": list(preset.overrides or ()),
                                      "protocols": protocols, "wall_seconds": wall, "compute_minutes": minutes,
                                      "trajectories": [r.to_dict() for r in records]}, compact=True)
    summary = {p: tables.summaries([r for r in records if r.protocol == p]) for p in protocols}
    write_json(out / "summary_metrics.json", summary)
    write_tables(out, summary)
    write_figures(out, records, names, protocols)
    judged = judge_claims(summary, records)
    paired = comparisons(records)
    goals = style_targets(out, names, records, preset)
    write_json(out / "claims.json", {"claims": judged, "targets": goals, "paired_differences": paired})
    write_text(out / "report.md", report_markdown(summary, judged, paired, preset, command, wall, minutes, goals))
    return {"results": str(out / "results.json"), "report": str(out / "report.md")}
