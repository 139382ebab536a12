"""Issue 41's results file: the example robot (examples/planar_arm, a task from outside the library)

Regenerates: `results/planar_arm/RESULTS.md`
reported like the paper's tasks, from one reproduction of it.

    scdp reproduce --task examples.planar_arm:TASK --preset cpu --out runs/planar_cpu     (the main job)
    python3 benchmarks/example_task.py --run runs/planar_cpu --out results/planar_arm

Reads the run's claims.json and stage_times.json (nothing is recomputed) and writes into ``--out``:
``RESULTS.md`` (the forced-style gap on D̂ and on each observer's accuracy at 50 %, SCDP − DP on
T_fa, D̂ and Ê, each paired on the same scenes and noise with its 95 % interval, and the stages'
compute minutes) beside copies of the run's report.md, claims.json and summary_metrics.json.
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

TASK = "planar_arm"
SETS = ("ambiguous", "non_ambiguous")


def _interval(row: dict) -> str:
    mark = " *" if row["lo"] > 0 or row["hi"] < 0 else ""
    return f"{row['mean']:+.3f} [{row['lo']:+.3f}, {row['hi']:+.3f}]{mark}"


def success_lines(summary: dict) -> list[str]:
    """Each method's success rate per scene set (with its 95 % interval), from summary_metrics.json."""
    sets = summary["random"][TASK]
    methods = list(sets[SETS[0]])
    lines = ["", "## Success", "", "| method | " + " | ".join(SETS) + " |", "|---|" + "---|" * len(SETS)]
    for m in methods:
        cells = [f"{sets[s][m]['success_ci']['mean']:.2f} [{sets[s][m]['success_ci']['lo']:.2f}, "
                 f"{sets[s][m]['success_ci']['hi']:.2f}]" for s in SETS]
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return lines


def results_markdown(claims: dict, times: dict, command: str, summary: dict) -> str:
    paired = [r for r in claims["paired_differences"] if r["task"] == TASK]
    lines = ["# The example robot: a planar 3-link arm defined outside the library", "",
             f"Command: `{command}`, then `python3 benchmarks/example_task.py` (this file). Task: "
             "`examples.planar_arm:TASK` (kinematic, 3 joints, end effector in the plane; docs/tasks.md).", "",
             "Paired on the same scenes and noise; 95 % bootstrap intervals over scenes; * = the interval excludes 0.", "",
             "## Forced styles: legible − efficient", "", "| scene set | measure | mean [95 % CI] | scenes |", "|---|---|---|---|"]
    for s in SETS:
        for r in paired:
            if r["scene_set"] == s and (r["a"], r["b"]) == ("scdp_legible", "scdp_efficient"):
                lines.append(f"| {s} | {r['metric']} | {_interval(r)} | {r['scenes']} |")
    observed = [t for t in claims["observer_targets"] if t["task"] == TASK]
    for t in observed:
        for row in [t["numbers"], *t.get("beside", {}).values()]:  # path-length, then the other observers
            if isinstance(row, dict) and (row.get("a"), row.get("b")) == ("scdp_legible", "scdp_efficient"):
                lines.append(f"| ambiguous | {row['metric']} | {_interval(row)} | {row['scenes']} |")
    lines += ["", "## SCDP − DP", "", "| scene set | measure | mean [95 % CI] | scenes |", "|---|---|---|---|"]
    for s in SETS:
        for r in paired:
            if r["scene_set"] == s and (r["a"], r["b"]) == ("scdp", "dp") and r["metric"] in ("transparency_fa", "d_hat", "e_hat"):
                lines.append(f"| {s} | {r['metric']} | {_interval(r)} | {r['scenes']} |")
    lines += success_lines(summary)
    lines += ["", "## Targets (as judged for the paper's tasks)", ""]
    lines += [f"- {'holds' if t['holds'] else 'MISSED'}: {t['target']}" for t in claims["targets"] if t["task"] == TASK]
    lines += [f"- {'holds' if t['holds'] else 'MISSED'}: {t['target']}" for t in observed]
    stages = {k.split("/", 1)[1]: v / 60 for k, v in times.items() if k.startswith(f"{TASK}/")}
    each = ", ".join(f"{stage} {m:.1f}" for stage, m in stages.items())
    lines += ["", f"Compute: {sum(stages.values()):.1f} min over every stage ({each}; minutes, this machine)."]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", required=True, help="a finished `scdp reproduce --task examples.planar_arm:TASK` folder")
    parser.add_argument("--out", default="results/planar_arm")
    args = parser.parse_args()
    run, out = Path(args.run), Path(args.out)
    claims = json.loads((run / "claims.json").read_text())
    times = json.loads((run / "stage_times.json").read_text())
    command = json.loads((run / "summary.json").read_text())["command"]
    out.mkdir(parents=True, exist_ok=True)
    for name in ("report.md", "claims.json", "summary_metrics.json"):
        shutil.copy(run / name, out / name)
    summary = json.loads((run / "summary_metrics.json").read_text())
    (out / "RESULTS.md").write_text(results_markdown(claims, times, command, summary))
    print(f"wrote {out / 'RESULTS.md'}")


if __name__ == "__main__":
    main()
