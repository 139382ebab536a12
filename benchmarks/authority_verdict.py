"""The style-authority candidates judged by the rule of results/authority/PROTOCOL.md (issue 76).

Regenerates: `results/authority/VERDICT.md`

    python benchmarks/authority_verdict.py

Reads each table that benchmarks/style_authority.py wrote (``results/authority/<name>.json``) and, for SCDP's
efficient → legible switch at 0.3 on each task, its separation ratio and observer-gain ratio to the switch at 0.
A candidate passes when both ratios are at least 0.5 on both tasks, with the gain at 0 above 0; the winner is the
passing candidate whose smallest ratio is largest. Nothing here is tuned: the rule was committed before any
candidate's table existed.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from scdp.evaluation.authority import NOTHING
from scdp.io import write_text

TABLES = {"cpu": "the committed cpu models (before any change)", "every_window": "A: every window",
          "rest_windows": "C: A + windows ranked by the path that remains",
          "turning_demos": "B: C + demos that change course, base retrained",
          "turning_point": "B': B with each turn's second course from the turn itself",
          "turning_all": "D: B' with every demo turning", "films_every_step": "E: B' with films on every denoising step",
          "turning_demos_trained": "B, planned by the trained sampler (every chunk from noise; a diagnosis, not a candidate)"}
TASKS = ("navigation", "block_reach")
AT, BAR = 0.3, 0.5
# candidates fixed after B' was measured must also keep, at AT, the committed models' absolute separation and gain
ABSOLUTE_TOO = ("turning_all", "films_every_step")


def switch_rows(table: dict, task: str) -> tuple[dict, dict]:
    """The summary rows of SCDP's efficient → legible switch at 0 and at :data:`AT`."""
    rows = table["tasks"][f"{task}/scdp"]["summary"]
    start = next(r for r in rows if r["first"] == "efficient" and r["fraction"] == 0.0)
    return start, next(r for r in rows if r["first"] == "efficient" and math.isclose(r["fraction"], AT))


def passes(sep: float, gain: float, gain_at_start: float) -> bool:
    return sep >= BAR and gain_at_start > NOTHING and gain >= BAR  # a NaN ratio (no gain at 0) never passes


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dir", default="results/authority")
    p.add_argument("--out", default="results/authority/VERDICT.md")
    args = p.parse_args(argv)
    folder = Path(args.dir)
    lines = ["# Style authority: the candidates against the protocol's rule", "",
             "`python benchmarks/authority_verdict.py`, from the tables of `benchmarks/style_authority.py` "
             "(`PROTOCOL.md` fixed the rule and the candidates before any was measured). SCDP's efficient → legible "
             f"switch at {AT} of the motion, as a ratio to the switch at 0 (same validation scenes, same noise); a "
             f"candidate passes when both ratios are at least {BAR} on both tasks, with an observer gain at 0 above 0. "
             "Each cell: the ratio, then the value at 0 → at 0.3 (separation in cm; observer gain: accuracy, "
             "legible-styled minus efficient-styled), since a ratio also grows when the start's effect shrinks. "
             f"Candidates fixed after B' was measured ({', '.join(ABSOLUTE_TOO)}) must also keep, at 0.3, at least the "
             "committed models' separation and gain on both tasks.", "",
             "| run | " + " | ".join(f"{t} separation | {t} observer gain" for t in TASKS) + " | passes |",
             "|---|" + "---|---|" * len(TASKS) + "---|"]
    verdicts = {}
    committed = json.loads((folder / "cpu.json").read_text())
    for name, words in TABLES.items():
        path = folder / f"{name}.json"
        if not path.exists():
            continue
        table = json.loads(path.read_text())
        cells, ok = [], True
        for task in TASKS:
            start, row = switch_rows(table, task)
            ok &= passes(row["separation_ratio"], row["gain_ratio"], start["gain"])
            if name in ABSOLUTE_TOO:  # PROTOCOL.md: no ratio won by a weaker start
                _, before = switch_rows(committed, task)
                ok &= row["separation"] >= before["separation"] and row["gain"] >= before["gain"]
            cells += [f"{row['separation_ratio']:.3f} ({100 * start['separation']:.1f} → {100 * row['separation']:.1f})",
                      f"{row['gain_ratio']:.2f} ({start['gain']:+.3f} → {row['gain']:+.3f})"
                      + ("" if start["gain"] > NOTHING else " no gain at 0")]
        candidate = name not in ("cpu", "turning_demos_trained")
        verdicts[name] = ok if candidate else None
        lines.append(f"| {words} (`{name}.md`) | " + " | ".join(cells) + f" | {('yes' if ok else 'no') if candidate else '–'} |")
    winners = [n for n, ok in verdicts.items() if ok]
    lines += ["", f"**Passing candidates: {', '.join(winners) if winners else 'none'}.** "
              + ("The design of the cpu preset changes to the winner." if winners else
                 "By the protocol, no candidate replaces the cpu preset's design; each is reported with its numbers."), ""]
    write_text(Path(args.out), "\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
