"""The analysis folder of a study: ``report.md``, ``summary.json``, ``responses.csv``, ``participants.csv``,
``accuracy.png``."""

from __future__ import annotations

from pathlib import Path

from scdp.io import atomic_path, check_output_path, write_json, write_text
from scdp.study.analysis import AT, AT_S, QUANTITIES, SMALL_SAMPLE, accuracy_figure, analyse, responses_csv
from scdp.study.record import Study
from scdp.study.screening import participants_csv

LABELS = {"final": "final accuracy", "t_kept": "t of the kept correct pick", "changes": "changes of mind",
          "confidence": "confidence (1-5)",
          **{f"correct_at_{round(100 * f)}": f"correct at {round(100 * f)} %" for f in AT},
          **{f"correct_at_{x:g}s": f"correct at {x:g} s" for x in AT_S}, "duration_s": "motion (s)"}


def _ci(v: dict) -> str:
    return f"{v['mean']:.3f} [{v['ci'][0]:.3f}, {v['ci'][1]:.3f}]"


def headline(summary: dict) -> str:
    """The report's first line: what kind of data it is, before anything else."""
    if summary["data"] == "simulated":
        return f"# SIMULATED DATA, not people: observer study of {summary['task']}"
    if summary["data"] == "mixed":
        return (f"# MIXED DATABASE: {summary['people']} people and {summary['simulated_participants']} simulated "
                f"participants (simulated left out): observer study of {summary['task']}")
    return f"# Observer study of {summary['task']}: {summary['people']} people"


def _pairs_table(claims: list[dict], bold: bool = True) -> list[str]:
    """A row per pair of methods; an interval that excludes zero in bold, unless ``bold`` is off (a sample
    below the size the report states: nothing there is a finding)."""
    lines = ["| A - B | " + " | ".join(LABELS[q] for q in QUANTITIES) + " |", "|---|" + "---|" * len(QUANTITIES)]
    pairs = {}
    for p in claims:
        pairs.setdefault((p["a"], p["b"]), {})[p["quantity"]] = p
    for (a, b), qs in pairs.items():
        cells = [f"**{_ci(qs[q])}**" if qs[q]["excludes_zero"] and bold else _ci(qs[q]) for q in QUANTITIES]
        lines.append(f"| {a} - {b} | " + " | ".join(cells) + " |")
    return lines


def _value(v, digits: int = 2) -> str:
    return "" if v is None else f"{v:.{digits}f}" if isinstance(v, float) else str(v)


def _data_lines(summary: dict) -> list[str]:
    """Whose answers these are, where they are not all people's."""
    lines = []
    if summary["data"] == "simulated":
        api = summary.get("simulated_through_api", 0)
        how = ("through the study's HTTP API, without a browser (`scdp study simulate --no-browser`)" if api == summary["participants"]
               else "through the real web page in headless Chromium" if not api else
               f"through the real web page in headless Chromium ({api} of them through the HTTP API, without a browser)")
        lines += [f"Every participant here is the simulated person of `scdp.study.person` answering {how}; none of it is "
                  "human data.", ""]
    if summary["data"] == "mixed":
        lines += [f"This database holds {summary['people']} people and {summary['simulated_participants']} simulated "
                  "participants (IDs `SIM-...`). Only people are analysed; the simulated ones are listed below with "
                  "that reason.", ""]
    return lines


def _method_lines(summary: dict, who: str, command: str, minutes: float) -> list[str]:
    """The command, the counts, the screening rules and the intervals, in one paragraph."""
    lines = []
    rules = summary["screening"]
    lines += [f"`{command}` ({minutes:.1f} min). {summary['participants']} {who} consented, "
              f"{summary['analysed_participants']} analysed, {len(summary['excluded'])} excluded, "
              f"{summary['responses']} main responses. Screening rules, fixed in study.json before data collection: "
              f"attention checks at least {rules['min_attention']:.0%} correct, instructed-response checks at least "
              f"{rules['min_instructed']:.0%} followed, the page hidden or unfocused during motions at most "
              f"{rules['max_away']} times, picks refused in at most {rules['max_capped']} trials, "
              f"a first pick within {rules.get('min_first_pick_s', 0.3):g} s of Start in at most "
              f"{rules.get('max_early', 0.5):.0%} of trials, the pick at {rules.get('ahead_at', 0.25):.0%} of motions the "
              f"{rules.get('ahead_observer', 'path_length')} observer cannot read by then "
              f"({rules.get('ahead_delay_s', 0.3):g} s behind) right no more often than guessing allows (binomial p at "
              f"least {rules.get('ahead_alpha', 0.01):g}), "
              f"at most {rules['max_replays']} replays, "
              f"playback lag at most {rules['max_lag']:.2f} of the motion, Confirm at least {rules['min_confirm_s']:.2f} s "
              f"after the motion. Intervals: 95 % {summary['bootstrap']['kind']} bootstrap, "
              f"{summary['bootstrap']['samples']} resamples (docs/study.md says why). t is the fraction of the motion "
              "the server's clock had reached at a pick; `t_kept` is 1 when the final answer is wrong.", ""]
    return lines


def markdown(summary: dict, people: list[dict], command: str, minutes: float) -> str:
    who = "simulated participants" if summary["data"] == "simulated" else "participants"
    lines = [headline(summary), ""]
    lines += _data_lines(summary)
    bold = not summary["small_sample"]
    bolding = ("**bold** where the interval excludes 0:" if bold else
               f"nothing in bold: below {SMALL_SAMPLE} analysed participants no interval is read as a finding:")
    if summary["small_sample"]:
        lines += [f"**Small sample**: {summary['analysed_participants']} analysed {who}. With fewer than 20 "
                  "participants the bootstrap intervals are rough and a design's balance is incomplete; read them as "
                  "a pilot.", ""]
    lines += _method_lines(summary, who, command, minutes)
    if summary["responses"]:
        lines += ["![accuracy over the motion](accuracy.png)", ""]
    for scene_set, block in summary["sets"].items():
        lines += [f"## {scene_set} scenes", "",
                  "| method | responses | " + " | ".join(LABELS[q] for q in QUANTITIES)
                  + " | mean gap to the path-length observer's curve |",
                  "|---|---|" + "---|" * (len(QUANTITIES) + 1)]
        for m, v in block["methods"].items():
            lines.append(f"| {m} | {v['responses']} | " + " | ".join(_ci(v[q]) for q in QUANTITIES)
                         + f" | {v['gap_to_path_length_observer']:.3f} |")
        lines += ["", "Paired differences (A - B, within participant and scene through the crossed bootstrap); " + bolding,
                  "", *_pairs_table(block["paired"], bold), ""]
        lines += _observer_lines(block, summary.get("reaction_s", 0.0))
    if summary["interaction"]:
        lines += ["## Does the difference depend on the scene?", "",
                  "(A - B on ambiguous scenes) - (A - B on clear scenes), in the same resamples; " + bolding, "",
                  *_pairs_table(summary["interaction"], bold), ""]
    lines += _position_lines(summary) + _rating_lines(summary)
    lines += ["## Participants", "", "| " + " | ".join(PEOPLE_COLUMNS.values()) + " |",
              "|" + "---|" * len(PEOPLE_COLUMNS)]
    for p in people:
        cells = [_value(p[k]) if k != "reasons" else ("; ".join(p["reasons"]) or "analysed") for k in PEOPLE_COLUMNS]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    return "\n".join(lines)


PEOPLE_COLUMNS = {"pid": "participant", "row": "Latin-square row", "main_answered": "main trials",
                  "accuracy": "final accuracy", "attention": "attention checks", "instructed": "instructed checks",
                  "away": "away", "early": "early first picks",
                  "ahead": "right early where no observer reads it", "minutes": "minutes", "replays": "replays",
                  "lag": "playback lag",
                  "confirm_s": "s to Confirm", "reasons": "excluded because"}


def _observer_lines(block: dict, reaction_s: float) -> list[str]:
    """The observers on the very stimuli shown, read by fraction and by seconds (``reaction_s`` behind), and
    their A - B at the same points: the method comparison on both readings, beside the people's above."""
    first = next(iter(block["methods"].values()), None)
    if first is None or "observers_at" not in first:
        return []
    points = list(next(iter(first["observers_at"].values())))
    lines = [f"Observers on the same stimuli: share correct by fraction of the motion and by seconds of it (an "
             f"observer {reaction_s:g} s behind the motion, as a person reacts):", "",
             "| method | observer | " + " | ".join(LABELS[q] for q in points) + " |", "|---|---|" + "---|" * len(points)]
    for m, v in block["methods"].items():
        lines += [f"| {m} | {name} | " + " | ".join(f"{reads[q]:.3f}" for q in points) + " |"
                  for name, reads in v["observers_at"].items()]
    lines += ["", "Observers' A - B at the same points:", "",
              "| A - B | observer | " + " | ".join(LABELS[q] for q in points) + " |", "|---|---|" + "---|" * len(points)]
    pairs = {}
    for d in block["observer_paired"]:
        pairs.setdefault((d["a"], d["b"], d["observer"]), {})[d["quantity"]] = d["difference"]
    lines += [f"| {a} - {b} | {name} | " + " | ".join(f"{diff[q]:+.3f}" for q in points) + " |"
              for (a, b, name), diff in pairs.items()]
    return lines + [""]


def _position_lines(summary: dict) -> list[str]:
    checks, bold = summary.get("position"), not summary["small_sample"]
    if not checks:
        return []
    lines = ["## Button position", "",
             "The target's button is an independent draw per trial, balanced across a Latin-square row's successive "
             "participants. Bias: the share of answers on a button less the share of targets on it (0: none); "
             "**bold** where its interval excludes 0.", "",
             "| button | responses with the target on it | share of answers on it | answers less targets | accuracy "
             "when the target is on it |", "|---|---|---|---|---|"]
    for p in checks["positions"]:
        excess = _ci(p["excess"])
        acc = _ci(p["accuracy"]) if p["accuracy"]["mean"] is not None else ""
        lines.append(f"| {p['position']} | {p['responses_with_target_here']} | {_ci(p['share_chosen'])} | "
                     f"{f'**{excess}**' if p['biased'] else excess} | {acc} |")
    verdict = "some button was favoured" if checks["any_bias"] else "no button was favoured beyond chance"
    lines += ["", f"Position bias: {verdict}."]
    if checks["adjusted_final"]:
        lines += ["", "Final accuracy A - B adjusted for the target's button (each button weighs the same):", "",
                  "| A - B | adjusted final accuracy |", "|---|---|"]
        lines += [f"| {c['a']} - {c['b']} | {f'**{_ci(c)}**' if c['excludes_zero'] and bold else _ci(c)} |"
                  for c in checks["adjusted_final"]]
    lines += [f"- {c['a']} - {c['b']} is not adjusted: {c['why']}." for c in checks.get("dropped", [])]
    return lines + [""]


def _rating_lines(summary: dict) -> list[str]:
    ratings = summary.get("ratings", {})
    if not ratings.get("methods"):
        return []
    lines = ["## Ratings at the end of the study", "",
             f"{ratings['participants']} analysed participants each rated one motion per method (1..7; "
             "participant bootstrap, 95 %).", "", "| method | legible | predictable |", "|---|---|---|"]
    for m, v in ratings["methods"].items():
        lines.append(f"| {m} | " + " | ".join(_ci(v[q]) if q in v else "" for q in ("legible", "predictable")) + " |")
    lines += ["", "| A - B | rating | difference |", "|---|---|---|"]
    lines += [f"| {c['a']} - {c['b']} | {c['quantity']} | {f'**{_ci(c)}**' if c['excludes_zero'] else _ci(c)} |"
              for c in ratings["paired"]]
    return lines + [""]


def write_analysis(study: Study, participants: list[dict], rows: list[dict], out, *, command: str,
                   ratings: list[dict] = (), minutes_so_far: float = 0.0, force: bool = False, seed: int = 0) -> dict:
    """Analyse ``rows`` (:meth:`scdp.study.store.Store.rows`) and ``ratings`` of ``participants``
    (:meth:`~scdp.study.store.Store.participants`) and write the analysis folder ``out``."""
    out = check_output_path(out, force=force)
    summary, table, people = analyse(study, participants, rows, ratings, seed=seed)
    summary["command"] = command
    with atomic_path(out, directory=True) as tmp:
        write_text(Path(tmp) / "responses.csv", responses_csv(table))
        write_text(Path(tmp) / "participants.csv", participants_csv(people))
        if summary["responses"]:
            accuracy_figure(summary).savefig(Path(tmp) / "accuracy.png", dpi=130)
        write_json(Path(tmp) / "summary.json", {**summary, "participant_table": people})
        write_text(Path(tmp) / "report.md", markdown(summary, people, command, minutes_so_far))
    return summary
