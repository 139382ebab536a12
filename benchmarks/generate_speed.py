"""How long does `scdp generate` take for 200 demos per task? (target: Block Reach < 60 s, Navigation < 10 s)

Regenerates: `results/benchmarks/generate_speed.md`

    python benchmarks/generate_speed.py            # writes results/benchmarks/generate_speed.{json,md}

Runs the generator in-process (no CLI start-up), single-threaded, seed 0, and records
wall time, success and failure counts.
"""

from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

from scdp.data.generate import generate_demos
from scdp.io import write_json, write_text

TARGETS = {"navigation": 10.0, "block_reach": 60.0}
OUT = Path("results/benchmarks/generate_speed.json")


def main(num_demos: int = 200) -> dict:
    rows = {}
    for task, limit in TARGETS.items():
        t0 = time.perf_counter()
        _, report = generate_demos(task, num_demos, seed=0, progress=False)
        seconds = time.perf_counter() - t0
        rows[task] = {"demos": report["demos"], "failures": report["failures"], "seconds": round(seconds, 2),
                      "target_seconds": limit, "within_target": seconds < limit}
    result = {"command": "python benchmarks/generate_speed.py", "cpu_count": os.cpu_count(),
              "python": platform.python_version(), "results": rows}
    write_json(OUT, result)
    lines = ["# Demonstration generation speed", "", f"Command: `{result['command']}` ({os.cpu_count()} CPU cores)", "",
             "| task | demos | failures | seconds | target |", "|---|---|---|---|---|"]
    lines += [f"| {t} | {r['demos']} | {r['failures']} | {r['seconds']} | < {r['target_seconds']} s |" for t, r in rows.items()]
    write_text(OUT.with_suffix(".md"), "\n".join(lines) + "\n")
    print(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    main()
