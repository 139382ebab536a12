"""``scdp study power``: the participants a study needs, by simulation over its own design (:mod:`scdp.study.power`)."""

from __future__ import annotations

import time
from pathlib import Path

from tqdm import tqdm

from scdp.errors import ScdpError
from scdp.io import atomic_path, check_output_path, write_json
from scdp.study.analysis import response_table
from scdp.study.make import read_study
from scdp.study.person import ParticipantModel
from scdp.study.power import PowerSettings, power
from scdp.study.rules import values_of
from scdp.study.screening import participant_table
from scdp.study.store import DATABASE_FILE, SIMULATED_FILE, Store, database_url


def pilot_responses(study, args) -> list[dict]:
    """The analysed main responses of the study's database (people's, or ``--simulated``'s)."""
    store = Store(database_url(args.study, args.database, file=SIMULATED_FILE if args.simulated else DATABASE_FILE))
    rows = store.rows()
    people = participant_table(study, store.participants(), rows)
    analysed = {p["pid"] for p in people if p["analysed"]}
    return [r for r in response_table(study, rows, analysed, set()) if r["analysed"]]


def markdown(study, result: dict, command: str, minutes: float) -> str:
    s = result["settings"]
    claim = "lower" if s["quantity"] == "t_kept" else "higher"
    lines = [f"# How many participants: {s['a']} vs {s['b']}, {s['quantity']}, {s['scene_set']} scenes ({study.task})", "",
             f"`{command}` ({minutes:.1f} min). Simulation over the study's own design (scdp.study.power): "
             f"{s['replicates']} simulated studies per size, each through the Latin square, the targets, the checks and "
             f"the attention and \"ahead\" screens (dropout {s['dropout']:.0%} for the other screens), analysed with "
             f"the crossed bootstrap ({s['samples']} resamples). Answers: {result['answers']}. A study detects the "
             f"difference when the 95 % interval of {s['a']} - {s['b']} lies wholly {'below' if claim == 'lower' else 'above'} 0.",
             "", "| participants | power [95 % interval] | mean difference | mean excluded |", "|---|---|---|---|"]
    for row in result["sizes"]:
        lo, hi = row["power_ci"]
        lines.append(f"| {row['participants']} | {row['power']:.2f} [{lo:.2f}, {hi:.2f}] | {row['difference']:+.3f} | "
                     f"{row['excluded']:.1f} |")
    best = result["recommended"]
    lines += ["", (f"**Recommended: {best} participants** (the smallest size of the grid with power at least "
                   f"{s['target']:.0%})." if best else
                   f"**No size of the grid reaches {s['target']:.0%} power**: the simulated difference is too small for "
                   f"{max(s['participants'])} participants; a larger grid, more scenes, or another quantity.")]
    return "\n".join(lines) + "\n"


def run(args) -> int:
    study = read_study(args.study)
    out = check_output_path(args.out, force=args.force)
    check_output_path(Path(out).with_suffix(".json"), force=args.force)
    settings = PowerSettings(**values_of(PowerSettings, args))
    settings.check(study)
    pilot = pilot_responses(study, args) if args.pilot else None
    if pilot is not None and not pilot:
        raise ScdpError("--pilot", "the database holds no analysed main response to draw pilot answers from")
    start = time.perf_counter()
    with tqdm(total=len(settings.participants) * settings.replicates, desc="simulated studies", unit="study") as bar:
        result = power(study, settings, ParticipantModel(**values_of(ParticipantModel, args)), pilot, bar.update)
    minutes = (time.perf_counter() - start) / 60
    result["minutes"] = round(minutes, 2)
    text = markdown(study, result, args.command_line, minutes)
    with atomic_path(out) as tmp:
        tmp.write_text(text)
    write_json(Path(out).with_suffix(".json"), result)
    print(text)
    return 0
