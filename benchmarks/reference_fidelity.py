"""Do the cheap Bézier reference paths score like executed demonstrations?

Regenerates: `results/benchmarks/reference_fidelity.md`

    python benchmarks/reference_fidelity.py        # writes results/benchmarks/reference_fidelity.{json,md}

Normalisation bounds come from task-space Bézier curves rather than simulated runs
(:mod:`scdp.scoring.reference`). This generates 50 demos per task, rebuilds each one's planned
Bézier curve from its stored control point, and compares D and E of the planned curve with
those of the executed path (relative error).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from scdp import scoring
from scdp.data.bezier import sample_by_arc_length
from scdp.data.generate import generate_demos
from scdp.io import write_json, write_text
from scdp.tasks import TASKS

OUT = Path("results/benchmarks/reference_fidelity.json")


def main(num_demos: int = 50) -> dict:
    rows = {}
    for name, task in TASKS.items():
        ds, _ = generate_demos(task, num_demos, seed=11, progress=False)
        cps = np.asarray(ds.attrs["control_points"])
        errs = []
        for i in range(ds.num_episodes):
            ep = ds.episode(i)
            executed = task.episode_path(ep)
            planned = sample_by_arc_length(executed[0], cps[i], ep["goals"][ep["target"]], task.step_size)
            d1, e1 = scoring.raw_scores(task, executed, ep["goals"], ep["target"])
            d0, e0 = scoring.raw_scores(task, planned, ep["goals"], ep["target"])
            errs.append((abs(d1 / d0 - 1), abs(e1 / e0 - 1)))
        errs = np.array(errs)
        rows[name] = {"demos": num_demos,
                      "D_rel_err_mean": float(errs[:, 0].mean()), "D_rel_err_max": float(errs[:, 0].max()),
                      "E_rel_err_mean": float(errs[:, 1].mean()), "E_rel_err_max": float(errs[:, 1].max())}
    result = {"command": "python benchmarks/reference_fidelity.py", "results": rows}
    write_json(OUT, result)
    lines = ["# Reference paths vs executed demonstrations", "", f"Command: `{result['command']}`", "",
             "| task | demos | D rel. err. mean | D max | E rel. err. mean | E max |", "|---|---|---|---|---|---|"]
    lines += [f"| {t} | {r['demos']} | {100 * r['D_rel_err_mean']:.2f} % | {100 * r['D_rel_err_max']:.2f} % | "
              f"{100 * r['E_rel_err_mean']:.2f} % | {100 * r['E_rel_err_max']:.2f} % |" for t, r in rows.items()]
    write_text(OUT.with_suffix(".md"), "\n".join(lines) + "\n")
    print(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    main()
