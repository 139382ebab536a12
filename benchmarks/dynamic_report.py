"""The report and figures of scenes that change during the motion (issue 65), from the JSON files
``scdp evaluate --events FAMILY --out DIR/TASK_FAMILY.json`` wrote (``benchmarks/dynamic.sh``).

Regenerates: `results/dynamic/report.md`, `results/dynamic/appear.png`

    python benchmarks/dynamic_report.py --dir results/dynamic

Per task and family: each method's success, switch latency, share switched within 2 chunks, legible
share after the event, observer accuracy and detour after the event; paired differences with 95 %
scene-bootstrap intervals; the verdict on each target of ``PROTOCOL.md``. One figure per family: the
first scene of each task, DP's and SCDP's paths, chunks coloured by style, the event marked.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from scdp.evaluation.dynamic import paired_difference
from scdp.evaluation.statistics import MIN_STARRED, PairedDifference
from scdp.io import write_text
from scdp.keys import EVENT_KINDS

TASKS = ("navigation", "block_reach")
COLOURS = {"legible": "tab:orange", "efficient": "tab:blue", "none": "0.45"}


def paired(result: dict, a: str, b: str, measure: str) -> PairedDifference:
    """a - b on ``measure``, paired by scene, from the per-scene rows (any two methods; a detour where both
    succeeded: :func:`scdp.evaluation.dynamic.paired_difference`)."""
    return paired_difference(result["methods"][a]["scenes"], result["methods"][b]["scenes"], measure, result["seed"],
                             (a, b))


def cell(d: PairedDifference | dict) -> str:
    d = d if isinstance(d, PairedDifference) else PairedDifference.from_row(d)
    failed = f" ({d.left_out} failed)" if d.left_out else ""
    return f"{d.cell()}{'*' if d.starred else ''}{failed}"


def verdicts(results: dict) -> list[str]:
    lines = ["| target | task | measured | holds |", "|---|---|---|---|"]
    for task in TASKS:
        appear, vanish = results.get((task, "appear")), results.get((task, "vanish"))
        if appear:
            scdp = appear["methods"]["scdp"]
            for rule, key in (("eq. 3", "switched_within_2"), ("the ellipse", "switched_within_2_ellipse")):
                share = scdp.get(key, float("nan"))
                lines.append(f"| 1. appear: SCDP in the style its criterion asks for from where the event found it ({rule}) "
                             f"within 2 chunks in ≥ 90 % of scenes | {task} | {share:.0%} | {'yes' if share >= 0.9 else 'no'} |")
            for other in ("dp", "scdp_efficient"):
                if other in appear["methods"]:
                    d = paired(appear, "scdp", other, "observer")
                    lines.append(f"| 2. appear: observer accuracy after the event, SCDP − {other} > 0 | {task} | {cell(d)} | "
                                 f"{'yes' if d.holds('>') else 'no'} |")
        if vanish:
            d = paired(vanish, "scdp", "scdp_legible", "detour")
            lines.append(f"| 3. vanish: detour after the event where both succeeded, SCDP − forced legible < 0 | {task} | "
                         f"{cell(d)} | {'yes' if d.holds('<') else 'no'} |")
    return lines


def tables(results: dict) -> list[str]:
    lines = []
    for (task, family), r in sorted(results.items()):
        rejected = r.get("rejected_at_event")
        said = "" if rejected is None else f", {rejected} drawn scenes rejected as not {family} from the event's point"
        lines += [f"### {task}, {family} ({r['scenes']} scenes, seed {r['seed']}{said}, {r['compute_minutes']:.1f} compute-min)",
                  "",
                  "| method | success | switch latency (chunks) | switched within 2 | legible after | observer after | detour after |",
                  "|---|---|---|---|---|---|---|"]
        for m, s in r["methods"].items():
            x = s["mean"]
            lat = "–" if not np.isfinite(x["latency"]) else f"{x['latency']:.2f}"
            within = "–" if not np.isfinite(x["latency"]) else f"{s['switched_within_2']:.2f}"
            legible = "–" if not np.isfinite(x["post_legible"]) else f"{x['post_legible']:.2f}"
            lines.append(f"| {m} | {x['success']:.2f} | {lat} | {within} | {legible} | {x['observer']:.3f} | {x['detour']:.3f} |")
        lines += ["", "| SCDP − | observer after | detour after (both succeeded) | success |", "|---|---|---|---|"]
        for other in (m for m in r["methods"] if m != "scdp"):
            lines.append(f"| {other} | " + " | ".join(cell(paired(r, "scdp", other, q)) for q in ("observer", "detour", "success"))
                         + " |")
        lines.append("")
    return lines


def figure(results: dict, family: str, path: Path) -> None:
    tasks = [t for t in TASKS if (t, family) in results]
    fig = Figure(figsize=(10, 4.2 * len(tasks)))
    axes = fig.subplots(len(tasks), 2, squeeze=False)
    for row, task in zip(axes, tasks):
        r = results[(task, family)]
        for ax, method in zip(row, ("dp", "scdp")):
            s = r["methods"][method]
            scene = s["scenes"][0]
            pts = np.asarray(scene["path"])[:, :2]
            n = s["n_action_steps"]
            for k, style in enumerate(scene["styles"]):
                seg = pts[k * n:(k + 1) * n + 1]
                ax.plot(seg[:, 0], seg[:, 1], color=COLOURS.get(style, "0.45"), lw=2)
            old, ev = np.asarray(scene["goals"])[:, :2], scene["event"]
            ax.scatter(old[:, 0], old[:, 1], s=80, facecolors="none", edgecolors="k", label="goals before")
            if ev is not None:
                new = np.asarray(ev["goals"])[:, :2]
                ax.scatter(new[:, 0], new[:, 1], s=60, c="k", label="goals after")
                ax.scatter(*new[ev["target"]], s=160, marker="*", c="tab:green", label="target after")
                ax.scatter(*pts[min(ev["step"], len(pts) - 1)], s=90, marker="x", c="tab:red", label="event")
            ax.set(title=f"{task}, {family}: {method}", aspect="equal")
            ax.grid(alpha=0.3)
    handles = [Line2D([], [], color=c, lw=2, label=f"{k} chunk") for k, c in COLOURS.items()]
    axes[0][1].legend(handles=handles + axes[0][1].get_legend_handles_labels()[0], fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dir", type=Path, default=Path("results/dynamic"))
    args = p.parse_args(argv)
    results = {}
    for task in TASKS:
        for family in EVENT_KINDS:
            f = args.dir / f"{task}_{family}.json"
            if f.exists():
                results[(task, family)] = json.loads(f.read_text())
    if not results:
        print(f"dynamic_report: error: --dir: no TASK_FAMILY.json in {args.dir}", file=sys.stderr)
        return 2
    minutes = sum(r["compute_minutes"] for r in results.values())
    lines = ["# Scenes that change during the motion (issue 65; round 2, issue 76)", "",
             f"`bash benchmarks/dynamic.sh` from the committed cpu models, as `PROTOCOL.md` fixed it before the run "
             f"({minutes:.1f} compute-min in all). Means over scenes; differences paired by scene with 95 % "
             "scene-bootstrap intervals (* excludes zero). Latency: chunks from the event to the first chunk in the "
             "new scene's style (0: the first chunk after it); – for planners without styles.", "",
             "## The protocol's targets", "", *verdicts(results), "", "## Every family", "", *tables(results),
             "Figures: " + ", ".join(f"[{k}]({k}.png)" for k in EVENT_KINDS) + " (the first scene of each task; chunks "
             "coloured by style: orange legible, blue efficient, grey without style; hollow: goals before the event, "
             "filled: after, star: the target after, x: where the event found the robot).",
             "", "Labels: the scene before the event by eq. 3 at the start; the scene after it as its family says from "
             "where the event finds a robot that went straight, by eq. 3 and the ellipse alike (drawn scenes that are "
             "not are rejected and counted); switching is judged from where the event found each robot. Limits: the "
             "models read two goals, so a distractor appears from out of play and vanishes into it; D̂, Ê and T are not "
             "measured after the event (the detour stands in for efficiency); no interval from fewer than "
             f"{MIN_STARRED} pairs is starred."]
    write_text(args.dir / "report.md", "\n".join(lines) + "\n")
    for family in EVENT_KINDS:
        if any((t, family) in results for t in TASKS):
            figure(results, family, args.dir / f"{family}.png")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
