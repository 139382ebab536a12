"""What a command pays for at start-up: ``scdp --help`` and a default ``scdp plan`` import no module
they do not run (results/benchmarks/responsive.md times them).

Each list names modules that would come back through a top-of-module import somewhere on the path:
the study's and the service's web stacks, the training stack, diffusers (DDPM's numbers are
:mod:`scdp.policies.noise_schedule`'s; diffusers' import pulls in ``torch._dynamo``), scipy, the exporter,
the renderer's image stack. A test runs the command in a fresh process and reads ``sys.modules``
at its end.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).parents[1]
CHECKPOINTS = ROOT / "results" / "cpu" / "navigation" / "checkpoints"
# modules no scdp command line needs before it knows its command
NOT_FOR_THE_PARSER = ("torch", "diffusers", "mujoco", "matplotlib", "cv2", "onnxruntime", "scipy", "fastapi", "uvicorn",
                      "sqlalchemy", "zarr", "accelerate", "gymnasium", "httpx", "playwright", "ruckig", "safetensors")
# modules a default plan (navigation, the committed cpu checkpoints) does not run
NOT_FOR_A_PLAN = ("diffusers", "scipy", "fastapi", "uvicorn", "starlette", "sqlalchemy", "zarr", "accelerate", "httpx", "playwright",
                  "ruckig", "onnx", "onnxscript", "pandas", "sklearn", "transformers", "peft")

PROBE = """
import json, sys
from scdp.cli import main
code = main(sys.argv[1:]) if len(sys.argv) > 1 else 0
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""


def loaded_after(*argv: str) -> tuple[int, set]:
    """(exit code, top-level names in sys.modules) of ``scdp ARGV`` run in a fresh process."""
    out = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True, check=True, cwd=ROOT)
    answer = json.loads(out.stdout.strip().splitlines()[-1])
    return answer["code"], {m.split(".")[0] for m in answer["modules"]} | set(answer["modules"])


def test_importing_the_command_line_loads_no_heavy_module():
    _, loaded = loaded_after()
    assert not loaded & set(NOT_FOR_THE_PARSER), sorted(loaded & set(NOT_FOR_THE_PARSER))


def test_a_default_plan_loads_only_what_it_runs(tmp_path):
    code, loaded = loaded_after("plan", "--task", "navigation", "--checkpoints", str(CHECKPOINTS), "--goals", "2.0,0.2",
                                "2.0,-0.2", "--out", str(tmp_path / "plan.json"))
    assert code == 0 and (tmp_path / "plan.json").is_file()
    assert {"torch", "onnxruntime"} <= loaded  # it did plan, with the exported graph
    assert not loaded & set(NOT_FOR_A_PLAN), sorted(loaded & set(NOT_FOR_A_PLAN))
