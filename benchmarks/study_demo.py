"""A simulated observer study on the cpu checkpoints: ``scdp study make``, ``simulate``, ``analyze``.

Regenerates: `results/study_demo/`

    python benchmarks/study_demo.py --run results/cpu --out results/study_demo

For each task, a study of dp, ld and scdp (3 ambiguous + 3 clear scenes, a practice trial, two
attention checks) is made from ``RUN/<task>/checkpoints`` in a temporary folder, ``--participants``
simulated participants take it through the real page in headless Chromium (noise 0.5 on the log
beliefs, a 0.5 s reaction delay, on the page's fake clock), and the analysis is
written to ``OUT/<task>/`` with the study's ``study.json`` (the frames and the database stay
behind: the CSV holds every response). **Simulated data, not human data.** Writes
``OUT/README.md`` with the commands and compute minutes. A control follows: 3 participants
without noise or delay (one per Latin-square row, so every stimulus once) in a database of their
own, analysed into ``OUT/<task>/control/``; ``OUT/README.md`` sets both beside the observer.
The same command gives the same answers on any machine; run it alone for honest minutes.
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
from scdp.io import write_text


def step(argv: list[str]) -> float:
    start = time.perf_counter()
    if scdp_main(argv) != 0:
        raise SystemExit(f"failed: scdp {' '.join(argv)}")
    return (time.perf_counter() - start) / 60


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", default="results/cpu", help="a cpu reproduction (its <task>/checkpoints)")
    p.add_argument("--out", default="results/study_demo")
    p.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    p.add_argument("--participants", type=int, default=30)
    p.add_argument("--note", default="", help="a line for OUT/README.md under the command (e.g. what else ran)")
    args = p.parse_args(argv)
    out = Path(args.out)
    command = " ".join(["python", "benchmarks/study_demo.py", *(argv if argv is not None else sys.argv[1:])])
    lines = ["# A simulated observer study (not human data)", "",
             f"`{command}`. Every participant is the simulated observer of `scdp.study.participant` answering "
             "through the real page in headless Chromium; docs/study.md explains the design and the analysis.", "",
             *([args.note, ""] if args.note else []),
             "| task | make min | simulate min | analyze min | report |", "|---|---|---|---|---|"]
    work = Path(tempfile.mkdtemp(prefix="scdp-study-demo-"))
    try:
        for task in args.tasks:
            study = work / task
            minutes = [step(["study", "make", "--task", task, "--checkpoints", str(Path(args.run) / task / "checkpoints"),
                             "--scenes", "3", "--completion-code", "SIMULATED", "--out", str(study)]),
                       step(["study", "simulate", "--study", str(study), "--participants", str(args.participants)]),
                       step(["study", "analyze", "--study", str(study), "--simulated", "--out", str(out / task), "--force"])]
            # the control: noiseless participants without delay, one per Latin-square row (3 methods: every
            # stimulus seen once), in a database of their own; their curves should be the observer's
            control = f"sqlite:///{(study / 'control.sqlite').as_posix()}"
            minutes[1] += step(["study", "simulate", "--study", str(study), "--database", control, "--participants", "3",
                                "--noise", "0", "--delay-s", "0"])
            minutes[2] += step(["study", "analyze", "--study", str(study), "--database", control,
                                "--out", str(out / task / "control"), "--force"])
            shutil.copy(study / "study.json", out / task / "study.json")
            lines.append(f"| {task} | " + " | ".join(f"{m:.1f}" for m in minutes) + f" | [{task}/report.md]({task}/report.md) |")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    lines += ["", f"How far each simulated accuracy curve lies from the project's path-length observer on the same paths "
              f"(mean |difference| over the motion; 0 is the same curve). The study: {args.participants} participants "
              "with noise 0.5 and a 0.5 s delay (`<task>/report.md`). The control: 3 participants without noise or "
              "delay, each stimulus seen once (`<task>/control/report.md`); they differ from the observer only in how "
              "often they look (every 0.15 s of motion) and in scaling costs without knowing the target.", "",
              "| task | scene set | method | observer's final accuracy | study: final accuracy | study: changes of "
              "mind | study: gap | control: final accuracy | control: gap |", "|---|---|---|---|---|---|---|---|---|"]
    for task in args.tasks:
        study_summary = json.loads((out / task / "summary.json").read_text())
        control_summary = json.loads((out / task / "control" / "summary.json").read_text())
        for scene_set, block in study_summary["sets"].items():
            for method, v in block["methods"].items():
                c = control_summary["sets"][scene_set]["methods"][method]
                lines.append(f"| {task} | {scene_set} | {method} | {v['observers']['path_length'][-1]:.3f} | "
                             f"{v['final']['mean']:.3f} | {v['changes']['mean']:.2f} | "
                             f"{v['gap_to_path_length_observer']:.3f} | {c['final']['mean']:.3f} | "
                             f"{c['gap_to_path_length_observer']:.3f} |")
    write_text(out / "README.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
