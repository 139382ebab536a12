"""Every verdict of a report under both normalisations of D̂, Ê and ĵ (:mod:`scdp.scoring.normalisation`).

The stored records are scored per scene; :func:`judge` reads them also over the training data
(:func:`scdp.evaluation.normalised.under`) and judges each reading alike: Tables 1-3, the paired
differences, the paper's claims, the style-effect targets, adaptivity and the observer targets.
What an observer reads and whether a run succeeded do not depend on the normalisation (the path is
the same), so the observers are measured once and read through both; the adaptivity shares on D̂
and Ê, and so the observer targets built on them, do depend on it. :func:`verdicts` sets the two
verdicts of every claim and target side by side (``claims.json``'s ``verdicts``, the report's first
section).

The training data's range of each model set (:func:`dataset_ranges`) is stored beside its demos
(``demos.normalisation.json``, :func:`scdp.pipeline.stages.demos_range`) and in ``results.json``
(``normalisation_ranges``), so a report rebuilt from ``results.json`` alone reads both.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from scdp.evaluation import adaptivity, claims, statistics, tables, targets
from scdp.evaluation.normalised import range_key, range_parts, under
from scdp.evaluation.observer_targets import observer_targets
from scdp.evaluation.records import FAILURE_AWARE, TrajectoryRecord
from scdp.keys import DATASET_NORMALISATION, NORMALISATIONS, PER_LAYOUT, RANDOM, SCENE_NORMALISATION
from scdp.pipeline.stages import demos_range
from scdp.scoring import NORMALISATION_NAMES, DatasetRange

CAPTIONS = {SCENE_NORMALISATION: "D̂, Ê per scene", DATASET_NORMALISATION: "D̂, Ê, ĵ over the training data"}
SUFFIX = {SCENE_NORMALISATION: "", DATASET_NORMALISATION: "_dataset"}  # table1.md, table1_dataset.md, ...


@dataclass
class Reading:
    """One normalisation's judgement of a report's records."""

    normalisation: str
    records: list[TrajectoryRecord]
    summary: dict  # {protocol: tables.summaries}
    claims: list[dict]
    paired: list[dict]
    targets: list[dict]
    adaptivity: list[dict]
    observer_targets: list[dict]

    def to_dict(self) -> dict:
        return {"claims": self.claims, "targets": self.targets, "paired_differences": self.paired,
                "adaptivity": self.adaptivity, "observer_targets": self.observer_targets}


@dataclass(frozen=True)
class Rendered:
    """What the report shows of one :class:`Reading`, each block as Markdown ("" where it has none):
    the random-scene Tables 1-2, the per-layout Table 3, the paired differences, adaptivity, the
    style-effect targets and the paper's claims. :func:`render` makes it for either normalisation; the
    report puts each reading's headings around it."""

    random_tables: str
    layout_table: str
    paired: str
    adaptivity: str
    targets: str
    claims: str


def render(reading: Reading) -> Rendered:
    """The one rendering of a reading's tables, differences, adaptivity, targets and claims."""
    caption, summary = CAPTIONS[reading.normalisation], reading.summary
    random = ("\n".join([tables.table1(summary[RANDOM], reading=caption), "", tables.table2(summary[RANDOM], reading=caption)])
              if RANDOM in summary else "")
    claim_lines = ["| task | models | claim | holds | numbers |", "|---|---|---|---|---|"]
    claim_lines += [f"| {c['task']} | {tables.PROTOCOL_NAMES[c['protocol']]} | {c['claim']} | "
                    f"{'yes' if c['holds'] else '**no**'} | `{json.dumps(c['numbers'])}` |" for c in reading.claims]
    return Rendered(random, tables.table3(summary, reading=caption) if PER_LAYOUT in summary else "",
                    statistics.comparisons_markdown(reading.paired) if reading.paired else "",
                    adaptivity.adaptivity_markdown(reading.adaptivity) if reading.adaptivity else "",
                    targets.targets_markdown(reading.targets) if reading.targets else "",
                    "\n".join(claim_lines))


def dataset_ranges(out: Path, records: list[TrajectoryRecord], stored: dict | None = None) -> dict[str, DatasetRange]:
    """The training data's range for every model set the records come from: ``stored`` (a
    ``results.json``'s), else the demos in ``out`` (``<task>/demos.zarr``, per-layout
    ``<task>/per_layout/layout_k/demos.zarr``). A model set whose demos are absent is left out."""
    ranges = dict(stored or {})
    for key in sorted({range_key(r) for r in records} - set(ranges)):
        task, layout = range_parts(key)
        folder = out / task / (f"{PER_LAYOUT}/{layout}" if layout else "")
        found = demos_range(folder)
        if found is not None:
            ranges[key] = found
    return ranges


def comparisons(records: list[TrajectoryRecord]) -> list[dict]:
    """Paired differences (SCDP − DP, − LD, − Dataset, ...) on the random-scene protocol's two sets
    (T, T_fa, D̂, Ê), and T and T_fa on the layout groups (repeats of a layout scene resampled together)."""
    random = [r for r in records if r.protocol == RANDOM]
    return (statistics.paired_comparisons(random, tables.SETS)
            + statistics.paired_comparisons(random, tables.LAYOUT_GROUPS, metrics=("transparency", FAILURE_AWARE)))


def judge_claims(summary: dict, records: list[TrajectoryRecord]) -> list[dict]:
    """The paper's claims on each protocol that ran (per-layout: layouts 1-3 vs 4-6)."""
    of = {p: [r for r in records if r.protocol == p] for p in summary}
    judged = claims.claims(summary[RANDOM], records=of[RANDOM]) if RANDOM in summary else []
    if PER_LAYOUT in summary:
        judged += claims.claims(summary[PER_LAYOUT], tables.LAYOUT_GROUPS, protocol=PER_LAYOUT)
    return judged


def judge(records: list[TrajectoryRecord], protocols: list[str], ranges: dict, measured: dict,
          subset_gaps: dict | None = None) -> dict[str, Reading]:
    """Each normalisation's :class:`Reading` of the records (``dataset`` only where every model set's
    range is known). ``measured``: the random-scene records' observer measures
    (:func:`scdp.evaluation.observation.measure_all`), read through the copies; ``subset_gaps``: the
    training data's style-subset gaps, per scene only (the forced-gap target reports its share)."""
    out = {}
    random = [r for r in records if r.protocol == RANDOM]
    for name in NORMALISATIONS:
        if name == DATASET_NORMALISATION and any(range_key(r) not in ranges for r in records):
            continue
        mine = under(records, name, ranges)
        own = [c for r, c in zip(records, mine) if r.protocol == RANDOM]
        seen = {o: m.read_through(random, own) for o, m in measured.items()}
        summary = {p: tables.summaries([r for r in mine if r.protocol == p]) for p in protocols}
        shares = adaptivity.adaptivity(own, seen)
        out[name] = Reading(name, mine, summary, judge_claims(summary, mine), comparisons(mine),
                            targets.targets(own, subset_gaps if name == SCENE_NORMALISATION else None), shares,
                            observer_targets(own, seen, shares) if own else [])
    return out


def verdicts(readings: dict[str, Reading]) -> list[dict]:
    """Every claim and target with its verdict under each normalisation (None: not judged there)."""
    rows: dict = {}
    for name, reading in readings.items():
        for kind, judged in (("claim", reading.claims), ("target", reading.targets), ("observer target", reading.observer_targets)):
            for row in judged:
                label = row.get("claim", row.get("target"))
                key = (row["task"], row.get("protocol", RANDOM), kind, label)
                rows.setdefault(key, {"task": row["task"], "protocol": key[1], "kind": kind, "verdict": label,
                                      **{n: None for n in NORMALISATIONS}})[name] = bool(row["holds"])
    return list(rows.values())


def verdicts_markdown(rows: list[dict]) -> str:
    """The verdicts side by side, those that differ first and in bold."""
    word = {True: "holds", False: "missed", None: "not judged"}
    differ = [r for r in rows if r[SCENE_NORMALISATION] != r[DATASET_NORMALISATION]]
    lines = [f"{len(differ)} of {len(rows)} verdicts differ between the two readings. **{NORMALISATION_NAMES[SCENE_NORMALISATION]}**: "
             "D and E min-max over the scene's 100 reference paths, ĵ over the task's range (every other section of this "
             f"report). **{NORMALISATION_NAMES[DATASET_NORMALISATION]}**: D and E min-max over the task's training "
             "demonstrations, ĵ over the training scenes' j (section *Read over the training data*). Neither is the "
             "paper's by construction: its demonstrations came from fixed layouts, where a layout's training data and the "
             "scene coincide. The observers' readings and success do not depend on the normalisation.", "",
             "| task | models | kind | claim or target | per scene | over the training data |", "|---|---|---|---|---|---|"]
    for r in differ + [r for r in rows if r not in differ]:
        bold = "**" if r in differ else ""
        lines.append(f"| {r['task']} | {tables.PROTOCOL_NAMES.get(r['protocol'], r['protocol'])} | {r['kind']} | {r['verdict']} | "
                     f"{bold}{word[r[SCENE_NORMALISATION]]}{bold} | {bold}{word[r[DATASET_NORMALISATION]]}{bold} |")
    return "\n".join(lines) + "\n"


def ranges_markdown(ranges: dict[str, DatasetRange]) -> str:
    lines = ["| model set | demos | D range | E range | j range |", "|---|---|---|---|---|"]
    lines += [f"| {key} | {r.demos} | [{r.d_min:.3f}, {r.d_max:.3f}] | [{r.e_min:.3f}, {r.e_max:.3f}] | [{r.j_min:.3f}, {r.j_max:.3f}] |"
              for key, r in sorted(ranges.items())]
    return "\n".join(lines) + "\n"


def dataset_markdown(reading: Reading, ranges: dict[str, DatasetRange]) -> str:
    """The report's section for the reading over the training data: its ranges, tables, paired
    differences, adaptivity, claims and targets."""
    lines = ["Every record rescored from its stored raw D and E (nothing rolled out again): D̂ = (D − D_min) / (D_max − D_min) "
             "and Ê likewise over the training demonstrations of the models' own demos (each scored as a rollout is), "
             "ĵ = j min-max over the training scenes, clipped to [0, 1]. The observers, legibility and success are "
             "unchanged; the forced-gap target's share of the training subsets' gap is left out (those gaps are per "
             "scene).", "", ranges_markdown(ranges), ""]
    shown = render(reading)
    for caption, block in (("", shown.random_tables), ("", shown.layout_table),
                           ("Paired differences (same scenes, same noise; 95 % bootstrap intervals, * = excludes zero):",
                            shown.paired),
                           ("Adaptivity (only the D̂ and Ê columns differ from the per-scene reading):", shown.adaptivity),
                           ("Style-effect targets:", shown.targets)):
        if block:
            lines += [caption, "", block, ""] if caption else [block, ""]
    lines += ["The paper's claims:", "", shown.claims]
    return "\n".join(lines) + "\n"
