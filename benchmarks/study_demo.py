"""A simulated observer study on the cpu checkpoints, sized before it runs: ``scdp study make``, ``power``,
``simulate``, ``analyze``.

Regenerates: `results/study_demo/`

    python benchmarks/study_demo.py --run results/cpu --out results/study_demo

For each task, a study of dp, ld and scdp (``--scenes`` ambiguous + ``--scenes`` clear scenes, each shown toward
a target drawn per participant, a practice trial, two attention checks and an instructed-response check) is made
from ``RUN/<task>/checkpoints`` in a temporary folder with a fixed salt (the same study on any machine). ``scdp
study power`` sizes it first: the participants needed to detect scdp - dp in accuracy at 50 % of the motion on
ambiguous scenes at 80 % power (``OUT/<task>/power.md``); that many simulated participants then take it through
the study's HTTP API (``simulate --no-browser``: noise 0.5 on the log beliefs, a 0.5 s reaction delay, the
server's virtual clock), and the analysis is written to ``OUT/<task>/`` with the study's ``study.json`` (the
frames and the database stay behind: the CSV holds every response). When no size of the grid reaches the power,
the largest is run and the README says so. **Simulated data, not human data.** A control follows: 3
participants without noise, 0.3 s behind the motion, through the real page in headless Chromium (one per
Latin-square row) in a database of their own, analysed into ``OUT/<task>/control/``; ``OUT/README.md`` sets both beside the observer,
with the compute minutes of every step. Run it alone for honest minutes.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

from scdp.cli import main as scdp_main
from scdp.io import write_json, write_text

CONTROL_DELAY_S = 0.3  # the control's reaction delay: the study's min_first_pick_s, the early rule's bound


def step(argv: list[str]) -> float:
    start = time.perf_counter()
    if scdp_main(argv) != 0:
        raise SystemExit(f"failed: scdp {' '.join(argv)}")
    return (time.perf_counter() - start) / 60


def run_task(task: str, study: Path, out: Path, args) -> str:
    """Make, size, simulate and analyse one task's study; its README row."""
    minutes = [step(["study", "make", "--task", task, "--checkpoints", str(Path(args.run) / task / "checkpoints"),
                     "--scenes", str(args.scenes), "--salt", "5eed", "--completion-code", "SIMULATED", "--out", str(study)])]
    minutes.append(step(["study", "power", "--study", str(study), "--participants", *map(str, args.sizes),
                         "--replicates", str(args.replicates), "--out", str(study / "power.md")]))
    sizing = json.loads((study / "power.json").read_text())
    count = sizing["recommended"] or max(args.sizes)
    power = next(row["power"] for row in sizing["sizes"] if row["participants"] == count)
    minutes.append(step(["study", "simulate", "--study", str(study), "--participants", str(count), "--no-browser"]))
    minutes.append(step(["study", "analyze", "--study", str(study), "--simulated", "--out", str(out), "--force"]))
    # the control: noiseless participants through the real page, one per Latin-square row, in a database of their
    # own, reacting CONTROL_DELAY_S behind the motion (just past the early-pick rule, which excludes a participant
    # without any delay); their curves should be the observer's, that far behind
    control = f"sqlite:///{(study / 'control.sqlite').as_posix()}"
    minutes[2] += step(["study", "simulate", "--study", str(study), "--database", control, "--participants", "3",
                        "--noise", "0", "--delay-s", str(CONTROL_DELAY_S)])
    minutes[3] += step(["study", "analyze", "--study", str(study), "--database", control, "--out", str(out / "control"),
                        "--force"])
    for name in ("study.json", "power.md", "power.json"):  # the analysis replaced OUT/<task>: these join it after
        shutil.copy(study / name, out / name)
    said = "recommended" if sizing["recommended"] else "no size reached 80 %: the largest run"
    row = (f"| {task} | {args.scenes} | {count} ({power:.2f}) | " + " | ".join(f"{m:.1f}" for m in minutes)
           + f" | [{said}]({task}/power.md) | [{task}/report.md]({task}/report.md) |")
    write_json(out / "demo.json", {"row": row, "minutes": [round(m, 2) for m in minutes]})  # kept, whatever follows
    return row


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", default="results/cpu", help="a cpu reproduction (its <task>/checkpoints)")
    p.add_argument("--out", default="results/study_demo")
    p.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    p.add_argument("--scenes", type=int, default=12, help="scenes per set (default 12)")
    p.add_argument("--sizes", type=int, nargs="+", default=[48, 96, 144, 192], help="participant counts power tries")
    p.add_argument("--replicates", type=int, default=200, help="simulated studies per size (default 200)")
    p.add_argument("--note", default="", help="a line for OUT/README.md under the command (e.g. what else ran)")
    args = p.parse_args(argv)
    out = Path(args.out)
    command = " ".join(["python", "benchmarks/study_demo.py", *(argv if argv is not None else sys.argv[1:])])
    lines = ["# A simulated observer study, sized before it ran (not human data)", "",
             f"`{command}`. Each study is sized by `scdp study power` (the participants needed to detect scdp - dp in "
             "accuracy at 50 % of the motion on ambiguous scenes at 80 % power, simulated over the study's own design), "
             "then taken by that many simulated participants through the study's HTTP API (`scdp study simulate "
             "--no-browser`); docs/study.md explains the design and the analysis.", "",
             *([args.note, ""] if args.note else []),
             "| task | scenes per set | participants (power) | make min | power min | simulate min | analyze min | "
             "sizing | report |", "|---|---|---|---|---|---|---|---|---|"]
    work = Path(tempfile.mkdtemp(prefix="scdp-study-demo-"))
    try:
        for task in args.tasks:
            lines.append(run_task(task, work / task, out / task, args))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    lines += ["", "How far each simulated accuracy curve lies from the project's path-length observer on the same paths "
              "(mean |difference| over the motion; 0 is the same curve). The study: simulated participants with noise "
              "0.5 and a 0.5 s delay (`<task>/report.md`). The control: 3 participants without noise through the real "
              f"page, {CONTROL_DELAY_S:g} s behind the motion (`<task>/control/report.md`; without any delay the early-pick "
              "rule excludes them, as it should); they differ from the observer in that delay, in how often they look "
              "(every 0.15 s of motion), in scaling costs without knowing the target, and in seeing where a motion "
              "stopped at its end.", "",
              "| task | scene set | method | observer's final accuracy | study: final accuracy | study: changes of "
              "mind | study: gap | control: final accuracy | control: gap |", "|---|---|---|---|---|---|---|---|---|"]
    for task in args.tasks:
        study_summary = json.loads((out / task / "summary.json").read_text())
        control_summary = json.loads((out / task / "control" / "summary.json").read_text())
        for scene_set, block in study_summary["sets"].items():
            for method, v in block["methods"].items():
                c = control_summary["sets"].get(scene_set, {}).get("methods", {}).get(method)
                control = f"{c['final']['mean']:.3f} | {c['gap_to_path_length_observer']:.3f}" if c else "– | –"
                lines.append(f"| {task} | {scene_set} | {method} | {v['observers']['path_length'][-1]:.3f} | "
                             f"{v['final']['mean']:.3f} | {v['changes']['mean']:.2f} | "
                             f"{v['gap_to_path_length_observer']:.3f} | {control} |")
    write_text(out / "README.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
