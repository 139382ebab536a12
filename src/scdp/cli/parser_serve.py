"""The ``scdp`` serve commands' arguments and help text (assembled by :mod:`scdp.cli.parser`).

Standard library and scdp's light leaves only, as the parser, so ``scdp --help`` stays instant.
"""

from __future__ import annotations

from scdp import planners
from scdp.cli.parser_common import planning_args, task_arg
from scdp.cli.types import count, float_in, int_in, port, seed
from scdp.keys import TASK_NAMES
from scdp.serve.batching import BatchingOptions


def add_serve_parsers(sub) -> None:
    """``scdp serve | deploy``: the planners for a robot stack, and the simulated robot path."""
    p = sub.add_parser("serve", help="serve trained planners over HTTP/JSON for a robot stack (FastAPI + uvicorn)",
                       description="POST /v1/act returns the next action chunk for a state history and a scene "
                                   "(concurrent calls are batched into one network call); POST /v1/plan returns a "
                                   "whole simulated trajectory; GET /v1/health and /v1/info describe the service. "
                                   "A malformed request gets HTTP 422 with a one-line '<field>: <problem>'; an "
                                   "overloaded server answers 503. With --warm-skip, a client that sends the last answer back "
                                   "as 'previous' gets chunks started from it (docs/service.md). The OpenAPI schema "
                                   "is at /openapi.json.",
                       epilog="Example: scdp serve --task navigation --checkpoints runs/cpu/navigation/checkpoints, then "
                              "curl -s localhost:8000/v1/act -H 'content-type: application/json' "
                              "-d '{\"state_history\": [[0, 0, 0]], \"goals\": [[2, 0.3], [2, -0.3]]}'")
    task_arg(p)
    p.add_argument("--checkpoints", required=True, help="folder with base/, ld/, encoder/, style_legible/, style_efficient/")
    p.add_argument("--methods", nargs="+", choices=list(planners.names()), metavar="METHOD",
                   help="planners to serve (default: every one whose parts the folder must hold: dp, ld, ld_paper and "
                        "the scdp family, and scdp_paper when a style_paper_* folder is there); every part they need is "
                        "loaded and checked before the service listens")
    p.add_argument("--host", default="127.0.0.1", help="interface to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=port, default=8000, help="TCP port (default 8000)")
    for name, default, meta in BatchingOptions.flags():  # declared once, on the options' fields
        lo, hi = meta["range"]
        kind = int_in(lo, hi) if isinstance(default, int) else float_in(lo, hi, lo_open=meta.get("lo_open", False),
                                                                           unit=meta.get("unit", ""))
        p.add_argument(meta["flag"], dest=name, metavar=meta["flag"][2:].upper().replace("-", "_"), type=kind, default=default,
                       help=f"{meta['help']} (default {default:g})")
    planning_args(p, "serve")
    p.set_defaults(handler="serve:serve")

    p = sub.add_parser("deploy", help="the robot path in simulation: camera -> detected blocks -> plan -> 1 kHz execution",
                       description="Renders the Block Reach cell's RGB-D camera, detects the target (green) and distractor "
                                   "(blue) blocks, locates them in the base frame, plans with the chosen method from the "
                                   "executed state at every chunk, streams each chunk through Ruckig to 1 kHz jerk-limited "
                                   "joint positions and executes them on the MuJoCo Panda at 1 ms. Writes deploy.json (goals "
                                   "detected vs true, styles, success, 1 kHz limit ratios, tracking error, planning time per "
                                   "chunk), strip.png and deploy.mp4 into --out; with --scenes N also summary.json and one "
                                   "JSON per scene under scenes/.",
                       epilog="Example: scdp deploy --task block_reach --checkpoints runs/cpu/block_reach/checkpoints "
                              "--scene-seed 0 --out runs/deploy. A real cell: pass --camera with your calibration "
                              "(docs/deploy.md shows the format and the two interfaces to implement).")
    p.add_argument("--task", default="block_reach", choices=list(TASK_NAMES), help="block_reach (the only camera cell)")
    p.add_argument("--checkpoints", required=True, help="folder with base/, ld/, encoder/, style_legible/, style_efficient/")
    p.add_argument("--scene-seed", type=seed, default=0, help="seed of the random scene (goals, target, start; default 0)")
    p.add_argument("--scenes", type=count, default=1,
                   help="run this many scenes, seeds SCENE_SEED, SCENE_SEED+1, ...; media for the first (default 1)")
    p.add_argument("--method", choices=list(planners.names()), default="scdp", help="default scdp (style chosen per chunk)")
    p.add_argument("--camera", help="calibration JSON (default: the simulated cell's camera)")
    p.add_argument("--depth-noise", action="store_true", help="RealSense-like depth noise and holes")
    p.add_argument("--margin", type=float_in(0, 1, lo_open=True), default=0.9,
                   help="plan the 1 kHz motion within this fraction of the velocity/acceleration/jerk limits (default 0.9)")
    p.add_argument("--no-video", action="store_true", help="skip strip.png and deploy.mp4")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    planning_args(p, "deploy")
    p.set_defaults(handler="deploy:deploy")
