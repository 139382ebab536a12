"""Re-record the golden tiny-preset metrics, after a *deliberate* change of behaviour.

    python tests/golden/record.py "why the numbers changed"

Runs ``scdp reproduce --task all --preset tiny`` into a temporary folder and writes
``tiny_reproduce_metrics.json``; commit it with the reason in the commit message.
"""

import json
import sys
import tempfile
from pathlib import Path

from scdp.cli import main

HERE = Path(__file__).parent

if __name__ == "__main__":
    reason = sys.argv[1] if len(sys.argv) > 1 else ""
    with tempfile.TemporaryDirectory() as tmp:
        assert main(["reproduce", "--task", "all", "--preset", "tiny", "--out", tmp]) == 0
        rows = json.loads((Path(tmp) / "results.json").read_text())["trajectories"]
    keep = ("task", "protocol", "scene_set", "method", "target", "success", "styles", "metrics")
    golden = {"command": "scdp reproduce --task all --preset tiny --out OUT", "recorded_with": reason,
              "trajectories": [{k: r[k] for k in keep} for r in rows]}
    (HERE / "tiny_reproduce_metrics.json").write_text(json.dumps(golden, indent=1) + "\n")
