"""The analysis folder of a study: ``report.md``, ``summary.json``, ``responses.csv``, ``accuracy.png``."""

from __future__ import annotations

from pathlib import Path

from scdp.io import atomic_path, check_output_path, write_json, write_text
from scdp.study.analysis import AT, QUANTITIES, accuracy_figure, analyse, responses_csv

LABELS = {"final": "final accuracy", "t_kept": "t of the kept correct pick", "changes": "changes of mind",
          **{f"correct_at_{round(100 * f)}": f"correct at {round(100 * f)} %" for f in AT}}


def _ci(v: dict) -> str:
    return f"{v['mean']:.3f} [{v['ci'][0]:.3f}, {v['ci'][1]:.3f}]"


def markdown(summary: dict, command: str, minutes: float) -> str:
    who = "simulated participants" if summary["simulated"] else "participants"
    lines = [f"# Observer study: {summary['task']}", ""]
    if summary["simulated"]:
        lines += ["**Simulated data.** Every participant here is the simulated observer of `scdp.study.participant` "
                  "answering through the real web page in headless Chromium; none of it is human data.", ""]
    lines += [f"`{command}` ({minutes:.1f} min). {summary['participants']} {who}, {summary['analysed_participants']} "
              f"analysed ({len(summary['excluded'])} excluded: unfinished or a failed attention check), "
              f"{summary['responses']} main responses. Intervals: 95 % {summary['bootstrap']['kind']} bootstrap, "
              f"{summary['bootstrap']['samples']} resamples (docs/study.md says why). t is the fraction of the motion "
              "shown; `t_kept` is 1 when the final answer is wrong.", "", "![accuracy over the motion](accuracy.png)", ""]
    for scene_set, block in summary["sets"].items():
        lines += [f"## {scene_set} scenes", "",
                  "| method | responses | " + " | ".join(LABELS[q] for q in QUANTITIES) + " | mean gap to the path-length observer's curve |",
                  "|---|---|" + "---|" * (len(QUANTITIES) + 1)]
        for m, v in block["methods"].items():
            lines.append(f"| {m} | {v['responses']} | " + " | ".join(_ci(v[q]) for q in QUANTITIES)
                         + f" | {v['gap_to_path_length_observer']:.3f} |")
        lines += ["", "Paired differences (A - B, within participant and scene through the crossed bootstrap); "
                      "**bold** where the interval excludes 0:", "",
                  "| A - B | " + " | ".join(LABELS[q] for q in QUANTITIES) + " |", "|---|" + "---|" * len(QUANTITIES)]
        pairs = {}
        for p in block["paired"]:
            pairs.setdefault((p["a"], p["b"]), {})[p["quantity"]] = p
        for (a, b), qs in pairs.items():
            cells = []
            for q in QUANTITIES:
                text = _ci(qs[q])
                cells.append(f"**{text}**" if qs[q]["excludes_zero"] else text)
            lines.append(f"| {a} - {b} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def write_analysis(study: dict, rows: list[dict], out, *, command: str, minutes_so_far: float = 0.0,
                   force: bool = False, seed: int = 0) -> dict:
    """Analyse ``rows`` (:meth:`scdp.study.store.Store.rows`) and write the analysis folder ``out``."""
    out = check_output_path(out, force=force)
    summary, table = analyse(study, rows, seed=seed)
    summary["command"] = command
    with atomic_path(out, directory=True) as tmp:
        write_text(Path(tmp) / "responses.csv", responses_csv(table))
        if summary["responses"]:
            accuracy_figure(summary).savefig(Path(tmp) / "accuracy.png", dpi=130)
        write_json(Path(tmp) / "summary.json", summary)
        write_text(Path(tmp) / "report.md", markdown(summary, command, minutes_so_far))
    return summary
