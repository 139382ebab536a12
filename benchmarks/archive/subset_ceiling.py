"""What the style subsets themselves score: the ceiling a predictor that imitates them could reach.

    python benchmarks/subset_ceiling.py --runs results/cpu [--tasks navigation block_reach]

For each task's demonstrations (``RUN/TASK/demos.zarr``) every demo is scored against its own
scene (D̂, Ê, T; :func:`scdp.scoring.subsets.episode_scores`) and labelled ambiguous or clear by
eq. 3 at its start. The table gives the mean scores of all demos and of each style subset
(the top ``--fraction`` by D̂, by Ê, and by T) within each kind of scene. "T − all" is how far
a predictor that imitated that subset perfectly would beat the Dataset row there: a subset
whose own margin is below the issue's +0.10 cannot give a policy that clears it by imitation.
Writes ``RUNS/subset_ceiling.{json,md}``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from scdp.data.dataset import DemoDataset
from scdp.io import write_json, write_text
from scdp.scoring import SCORES, ambiguous_at_start, episode_scores, top_fraction

RANKINGS = {"legible (top D̂)": "d_hat", "efficient (top Ê, the paper)": "e_hat", "top T": "transparency"}


def ceiling(demos: Path, fraction: float) -> list[dict]:
    dataset = DemoDataset.load(demos)
    task_name = dataset.task
    scores = episode_scores(dataset)  # (E, 3): d_hat, e_hat, T
    ambiguous = ambiguous_at_start(dataset)
    groups = {"all demos": np.arange(dataset.num_episodes)}
    groups.update({name: top_fraction(scores[:, SCORES.index(col)], fraction) for name, col in RANKINGS.items()})
    rows = []
    for scene_set, mask in (("ambiguous", ambiguous), ("clear", ~ambiguous)):
        base_t = scores[mask, 2].mean()
        for name, idx in groups.items():
            sel = idx[mask[idx]]
            rows.append({"task": task_name, "scene_set": scene_set, "subset": name, "demos": int(len(sel)),
                         "d_hat": round(float(scores[sel, 0].mean()), 3), "e_hat": round(float(scores[sel, 1].mean()), 3),
                         "transparency": round(float(scores[sel, 2].mean()), 3),
                         "t_minus_all": round(float(scores[sel, 2].mean() - base_t), 3)})
    return rows


def markdown(rows: list[dict], command: str, minutes: float, fraction: float) -> str:
    lines = ["# What the style subsets themselves score", "",
             f"Command: `{command}` ({minutes:.1f} compute-min). Subsets: the top {fraction:.0%} of all demos by each "
             "ranking, split by whether the demo's scene is ambiguous at its start (eq. 3). \"T − all\" is the subset's "
             "mean T minus that of every demo in the same kind of scene: the margin over the Dataset a predictor that "
             "imitated the subset perfectly would have.", "",
             "| task | scenes | subset | demos | D̂ | Ê | T | T − all |", "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['task']} | {r['scene_set']} | {r['subset']} | {r['demos']} | {r['d_hat']:.3f} | {r['e_hat']:.3f} | "
              f"{r['transparency']:.3f} | {r['t_minus_all']:+.3f} |" for r in rows]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, default=Path("results/cpu"), help="a reproduce output folder")
    parser.add_argument("--tasks", nargs="+", default=["navigation", "block_reach"])
    parser.add_argument("--fraction", type=float, default=0.2, help="subset share (the preset's data.style_fraction)")
    args = parser.parse_args()
    t0 = time.process_time()
    rows = [r for task in args.tasks for r in ceiling(args.runs / task / "demos.zarr", args.fraction)]
    command = "python benchmarks/subset_ceiling.py --runs " + str(args.runs) + " --tasks " + " ".join(args.tasks)
    minutes = (time.process_time() - t0) / 60
    write_json(args.runs / "subset_ceiling.json", {"command": command, "compute_minutes": round(minutes, 2),
                                                   "fraction": args.fraction, "rows": rows})
    text = markdown(rows, command, minutes, args.fraction)
    write_text(args.runs / "subset_ceiling.md", text)
    print(text)


if __name__ == "__main__":
    main()
