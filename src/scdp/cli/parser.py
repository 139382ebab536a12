"""The ``scdp`` argument parser: every command, its options and its help text.

It imports only the standard library and scdp's light leaves (keys, errors, messages, config), so
``scdp --help`` is instant.
Each subparser names its handler as ``"module:function"`` inside :mod:`scdp.cli`.
"""

from __future__ import annotations

import argparse
import re

from scdp.cli.study_parser import add_study_parsers
from scdp.config.planning import DEVICE_FLAG, PlannerSpec, PlanningOptions
from scdp.errors import ScdpError
from scdp.keys import ALL_PLANNERS, PROTOCOLS, SCENE_MODES, STYLE_MODES, STYLES, TASK_NAMES
from scdp.messages import PREVIEW_CHARS, preview
from scdp.observers import CONFIDENCE


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line naming the argument (a long quoted value cut short)."""

    def error(self, message):
        message = re.sub(r"'([^']{%d,})'" % PREVIEW_CHARS, lambda m: preview(m.group(1)), message)
        match = re.match(r"argument ([^:]+): (.*)", message)
        if match:
            field = match.group(1)
            raise ScdpError("command" if field.startswith("<") else field, match.group(2))  # <command>: the subcommand
        match = re.match(r"the following arguments are required: (.+)", message)
        if match:  # the first missing argument is the field
            missing = match.group(1).split(", ")
            others = f"; also missing: {', '.join(missing[1:])}" if len(missing) > 1 else ""
            raise ScdpError(missing[0].split("/")[0], f"required{others} (see {self.prog} --help)")
        raise ScdpError(self.prog, message)


def point(text: str):
    """``1.5,0.2`` -> [1.5, 0.2] (an argparse type)."""
    try:
        return [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers like 1.5,0.2, got {preview(text)}") from None


def method_spec(text: str) -> PlannerSpec:
    """``dp``, ``scdp_blend`` or ``scdp:legible`` -> its :class:`PlannerSpec` (an argparse type)."""
    try:
        return PlannerSpec.parse(text)
    except ScdpError as err:
        raise argparse.ArgumentTypeError(err.message) from None


def _task_arg(p, **kw):
    p.add_argument("--task", required=True, help=" or ".join(TASK_NAMES), **kw)


def _device_arg(p):
    p.add_argument("--device", **DEVICE_FLAG)


def _planning_args(p):
    """The planning-time options: one flag per field of :class:`scdp.config.PlanningOptions`."""
    for flag, keywords in PlanningOptions.flags():
        p.add_argument(flag, **keywords)


def _set_arg(p):
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.FIELD=VALUE",
                   help="override one preset field, e.g. --set base.train.lr=3e-4 --set style.model.layers=3 "
                        "(sections: data, base, encoder, style, ld, evaluation, layouts; values are JSON); "
                        "recorded in every checkpoint and in results.json")


def _goals_arg(p, what: str):
    p.add_argument("--goals", type=int, default=None, metavar="N",
                   help=f"goals per random scene, 2..5: the target and N-1 distractors ({what})")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="scdp",
        description="Style-Conditioned Diffusion Policy: demonstrations, metrics, ambiguity and the paper's reproduction.",
        epilog="Start with `scdp reproduce --task navigation --preset cpu --out runs/cpu`, "
        "or `scdp generate --task navigation --num-demos 200 --seed 0 --out demos.zarr`.",
    )
    parser.add_argument("--threads", type=int, default=None, metavar="N",
                        help="CPU threads for torch (default: torch's choice, or OMP_NUM_THREADS). Idle threads "
                             "sleep rather than spin, so scdp shares cores gracefully (see scdp.threads)")
    sub = parser.add_subparsers(dest="command", metavar="<command>", parser_class=_Parser)

    p = sub.add_parser("generate", help="generate Bézier demonstrations in simulation into a zarr replay buffer",
                       description="Draw quadratic Bézier paths, execute them in the task's simulator, and store the successful ones.")
    _task_arg(p)
    p.add_argument("--num-demos", type=int, default=200, help="number of successful demos (default 200)")
    p.add_argument("--seed", type=int, default=0, help="seed of every random draw (default 0)")
    p.add_argument("--scenes", choices=SCENE_MODES, default="random", metavar="{random,fixed,layout_1..layout_6}",
                   help="random goals per demo (default), the authors' six fixed layouts in turn, "
                        "or one of them only (layout_k, as in the per-layout protocol)")
    _goals_arg(p, "default 2; the layouts hold 2")
    p.add_argument("--out", required=True, help="output .zarr folder")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="data:generate")

    p = sub.add_parser("inspect", help="print counts, lengths and curvature spread of a dataset")
    p.add_argument("path", help="a .zarr dataset")
    p.set_defaults(handler="data:inspect")

    p = sub.add_parser("plot-demos", help="draw a dataset's paths over their scenes")
    p.add_argument("path", help="a .zarr dataset")
    p.add_argument("--out", required=True, help="image file (.png or .pdf)")
    p.add_argument("--max-demos", type=int, default=50, help="how many demos to draw (default 50)")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="data:plot_demos")

    p = sub.add_parser("import-hdf5", help="import robomimic-style HDF5 demonstrations into zarr",
                       description="Import demonstrations whose actions are absolute next states. Steps after a "
                                   "'dones' flag and trailing actions beyond the robot's one-step reach (e.g. an "
                                   "all-zero terminal sentinel) are dropped with a warning; such a step anywhere "
                                   "else is refused.")
    p.add_argument("path", help="HDF5 file with data/demo_k/{states, actions, obs/object} and optional dones")
    _task_arg(p)
    p.add_argument("--goal-dim", type=int, default=None, metavar="N",
                   help="coordinates per goal in obs/object (default: the task's space, 2 or 3; "
                        "use 2 for Block Reach goals given on the table plane)")
    p.add_argument("--out", required=True, help="output .zarr folder")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="data:import_hdf5")

    p = sub.add_parser("ambiguity-report", help="calibrate ambiguity and compare the ellipse with eq. 3 on random scenes")
    _task_arg(p)
    p.add_argument("--scenes", type=int, default=10_000, help="random scenes to compare on (default 10000)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random scenes (default 0)")
    p.add_argument("--out", help="write the report as JSON here (and Markdown beside it)")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="ambiguity:report")

    p = sub.add_parser("plot-ellipse", help="draw the ellipse of ambiguity for one scene (the paper's Fig. 4b)")
    _task_arg(p)
    p.add_argument("--goals", type=point, nargs="+", required=True, help="goals as x,y (or x,y,z) ...")
    p.add_argument("--target", type=int, default=0, help="index of g* among --goals (default 0)")
    p.add_argument("--out", required=True, help="image file (.png or .pdf)")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="ambiguity:plot_ellipse")

    p = sub.add_parser("train", help="train one part: base, encoder, style or ld",
                       description="Train one part into its own checkpoint folder (model.safetensors + config.json). "
                       "Style predictors need a trained base and encoder (by default the sibling folders base/ and encoder/ of --out).")
    p.add_argument("part", choices=["base", "encoder", "style", "ld"], help="which part")
    _task_arg(p)
    p.add_argument("--data", help="demonstrations (.zarr); not needed for the encoder")
    p.add_argument("--out", help="checkpoint folder for this part, e.g. ckpt/base")
    p.add_argument("--preset", default="cpu", help="cpu (default), paper or tiny")
    _set_arg(p)
    _goals_arg(p, "the encoder's scenes; the same as --set data.goals=N; default the preset's, 2")
    p.add_argument("--style", choices=list(STYLES), default="legible", help="for part style (default legible)")
    p.add_argument("--design", choices=["scdp", "paper"], default="scdp",
                   help="for part style: the preset's style section (scdp, default) or the paper's design "
                        "(paper_style, for method scdp_paper; save it as style_paper_<style>)")
    p.add_argument("--base", help="for part style, and ld with ld.init=base: base checkpoint folder (default OUT/../base)")
    p.add_argument("--encoder", help="for part style: encoder checkpoint folder (default OUT/../encoder)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run from its last checkpoint")
    p.add_argument("--force", action="store_true", help="retrain over an existing checkpoint")
    p.add_argument("--dry-run", action="store_true", help="build the model only; print {part, parameters} as JSON")
    _device_arg(p)
    p.set_defaults(handler="train:train")

    p = sub.add_parser("plan", help="roll out one scene with dp, ld or scdp and save the trajectory as JSON")
    _task_arg(p)
    p.add_argument("--checkpoints", required=True, help="folder with base/, ld/, encoder/, style_legible/, style_efficient/")
    p.add_argument("--goals", type=point, nargs="+", required=True, help="goals as x,y (or x,y,z) ...")
    p.add_argument("--target", type=int, default=0, help="index of g* among --goals (default 0)")
    p.add_argument("--method", choices=list(ALL_PLANNERS), default="scdp", help="default scdp")
    p.add_argument("--style", choices=list(STYLE_MODES), default=None,
                   help="scdp only: auto lets the ellipse of ambiguity choose per chunk (default); refused with a "
                        "method that has no style choice (dp, ld, ld_paper, scdp_paper) or fixes another one")
    p.add_argument("--seed", type=int, default=0, help="seed of the sampler and start noise (default 0)")
    p.add_argument("--out", required=True, help="output .json")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    _planning_args(p)
    p.set_defaults(handler="plan:plan")

    p = sub.add_parser("export", help="write each diffusion checkpoint's denoiser as ONNX, checked against torch",
                       description="Exports the denoiser of base/ and ld/ in CHECKPOINTS (the U-Net with its style-film "
                                   "inputs) as model.onnx beside its weights, with onnx.json (opset, film layout, sampler, "
                                   "normalisation, parity). Each graph is compared with torch on random inputs before it is "
                                   "renamed into place; one off by more than 1e-4 is refused, naming the worst case.",
                       epilog="Then plan with it: scdp plan ... --runtime onnx (also evaluate, serve, deploy).")
    _task_arg(p)
    p.add_argument("checkpoints", help="checkpoint folder holding base/ (and ld/)")
    p.add_argument("--force", action="store_true", help="replace existing model.onnx / onnx.json")
    p.set_defaults(handler="export:export")

    p = sub.add_parser("evaluate", help="roll out methods on random ambiguous and clear scenes (or one layout): mean "
                                        "metrics and paired differences against a baseline with 95 %% intervals",
                       description="Rolls out every method on the same scenes with the same noise: --scenes ambiguous and "
                                   "--scenes clear random scenes (labelled by eq. 3 at the start) of the evaluation stream "
                                   "for --seed, or one fixed layout. Prints each method's mean metrics per scene set and "
                                   "its paired differences against --baseline (T_fa, T, D̂, Ê, success) with 95 %% "
                                   "bootstrap intervals. A new --seed gives scenes nobody has looked at.")
    _task_arg(p)
    p.add_argument("--checkpoints", required=True, help="checkpoint folder (see plan)")
    p.add_argument("--encoder", help="scene encoder folder, if not CHECKPOINTS/encoder (per-layout model sets)")
    p.add_argument("--methods", nargs="+", type=method_spec,
                   default=[PlannerSpec.parse(m) for m in ("dp", "ld", "scdp", "scdp_legible", "scdp_efficient")],
                   help="planners by name (dp, ld, ld_paper, scdp, scdp_paper, scdp_blend, ...) or scdp:<style> "
                        "(default: dp ld scdp scdp_legible scdp_efficient)")
    p.add_argument("--baseline", help="the method every other one is compared with (default dp, when evaluated)")
    p.add_argument("--scenes", type=int, default=50,
                   help="random scenes per set (ambiguous, clear), or rollouts of --layout (default 50)")
    p.add_argument("--layout", type=int, metavar="K",
                   help="roll out on the authors' layout K (1..6), the two targets in turn, instead of random scenes")
    p.add_argument("--seed", type=int, default=1, help="seed of scenes and sampling (default 1)")
    _goals_arg(p, "default: the scene encoder's count when an SCDP method is evaluated, else 2; not with --layout")
    p.add_argument("--out", help="write the summary JSON here")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    _planning_args(p)
    p.set_defaults(handler="evaluate:evaluate")

    p = sub.add_parser("reproduce", help="the main job: run every stage of the paper's reproduction",
                       description="Runs the reproduction stages in order, skipping those whose output is already valid "
                                   "and was made from exactly the current contents of its inputs (recipe, demos, upstream "
                                   "weights: content hashes, never file times), so a killed run resumes where it stopped and "
                                   "a changed input redoes what was made from it. Writes results.json, tables, figures, "
                                   "claims.json and report.md into --out.",
                       epilog="Protocols: 'random' trains one model set per task on demos of random scenes and evaluates it on "
                              "random ambiguous / non-ambiguous scenes and the six fixed layouts. 'per_layout' is the "
                              "authors' protocol: one model set per fixed layout (goal pair), trained on demos of that layout "
                              "only and evaluated on it. 'both' runs the two and reports them side by side (Table 3).")
    p.add_argument("--task", default="all", choices=[*TASK_NAMES, "all"], help="default all")
    p.add_argument("--preset", default="cpu", help="cpu (default), paper, or tiny (a smoke test)")
    _set_arg(p)
    p.add_argument("--out", default="runs/cpu", help="output folder (default runs/cpu)")
    p.add_argument("--protocol", default="random", choices=list(PROTOCOLS),
                   help="random-scene models (default), the authors' per-layout models, or both")
    p.add_argument("--layouts", type=int, nargs="+", metavar="K",
                   help="per-layout protocol: only these layouts (1..6; default all six)")
    _goals_arg(p, "demos, encoder and evaluation scenes; the same as --set data.goals=N; default 2, the paper's, "
                  "with the six layouts, which more goals leave out")
    p.add_argument("--seed", type=int, default=0,
                   help="training seed of every part (weight initialisation, shuffling, noise; default 0). "
                        "Demos and evaluation scenes keep their own seeds, so seeds compare the same scenes "
                        "(add --set data.seed=K for demos of their own)")
    p.add_argument("--adopt", action="store_true",
                   help="a run made before scdp recorded what each output was made from: take its finished outputs "
                        "(with this preset's recipes) as made from the current inputs and record them, instead of "
                        "redoing them. Only for a run you know is consistent")
    _device_arg(p)
    p.set_defaults(handler="reproduce:reproduce")

    p = sub.add_parser("verify", help="does your own trained run support the committed verdicts? (fresh scenes, side by side)",
                       description="Rolls out a reproduction's models (RUN/<task>/checkpoints, e.g. trained on your machine) "
                                   "with the committed run's preset on fresh random scenes of an evaluation seed neither run "
                                   "reported, judges the paper's claims, the style-effect and the observer targets with their 95 %% "
                                   "intervals, and prints each verdict beside the committed one. Weights trained on another "
                                   "processor differ in their last bits and beyond; the verdicts are what should agree.",
                       epilog="Example: scdp reproduce --preset cpu --out runs/mine && scdp verify runs/mine --against results/cpu")
    p.add_argument("run", help="the reproduction folder to check (its <task>/checkpoints)")
    p.add_argument("--against", default="results/cpu", help="the committed run (claims.json, results.json; default %(default)s)")
    p.add_argument("--scenes", type=int, default=50,
                   help="fresh ambiguous and clear scenes each, per task (default %(default)s: a few minutes for the cpu preset)")
    p.add_argument("--seed", type=int, default=1234, help="their evaluation seed (default %(default)s, which no committed result reports)")
    p.add_argument("--out", help="also write the comparison here as JSON (never over a file without --force)")
    p.add_argument("--force", action="store_true", help="replace --out")
    _device_arg(p)
    p.set_defaults(handler="verify:verify")

    p = sub.add_parser("report", help="rebuild a reproduction's tables, claims, figures and report.md from its results.json",
                       description="Recomputes every report file but results.json from the trajectories a results.json "
                                   "stores (nothing is rolled out or trained again): summary_metrics.json, Tables 1-3, "
                                   "claims.json, report.md and, unless --no-figures, Figure 2 and the observer-accuracy "
                                   "figure. The style-subset gaps and the training dataset's j range read OUT/<task>/demos.zarr "
                                   "where it exists.",
                       epilog="Example: scdp report results/cpu/results.json --force (rewrites results/cpu's report files; "
                              "git diff shows what changed)")
    p.add_argument("results", help="a results.json written by scdp reproduce")
    p.add_argument("--out", help="folder to write into (default: the folder of RESULTS)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG/PDF figures")
    p.add_argument("--confidence", type=float, default=CONFIDENCE, metavar="P",
                   help="the observer is confident once P(g* | path so far) stays at or above P to the end "
                        "(time to confidence; 0.5 <= P < 1, above one half the target outweighs every other goal together; "
                        "default %(default)s, as in the report of scdp reproduce)")
    p.add_argument("--force", action="store_true", help="replace existing report files")
    p.set_defaults(handler="reproduce:report")

    p = sub.add_parser("serve", help="serve trained planners over HTTP/JSON for a robot stack (FastAPI + uvicorn)",
                       description="POST /v1/act returns the next action chunk for a state history and a scene "
                                   "(concurrent calls are batched into one network call); POST /v1/plan returns a "
                                   "whole simulated trajectory; GET /v1/health and /v1/info describe the service. "
                                   "A malformed request gets HTTP 422 with a one-line '<field>: <problem>'; an "
                                   "overloaded server answers 503. The OpenAPI schema is at /openapi.json.",
                       epilog="Example: scdp serve --task navigation --checkpoints runs/cpu/navigation/checkpoints, then "
                              "curl -s localhost:8000/v1/act -H 'content-type: application/json' "
                              "-d '{\"state_history\": [[0, 0, 0]], \"goals\": [[2, 0.3], [2, -0.3]]}'")
    _task_arg(p)
    p.add_argument("--checkpoints", required=True, help="folder with base/, ld/, encoder/, style_legible/, style_efficient/")
    p.add_argument("--methods", nargs="+", choices=list(ALL_PLANNERS), metavar="METHOD",
                   help="planners to serve (default: every one whose parts the folder must hold: dp, ld, ld_paper and "
                        "the scdp family, and scdp_paper when a style_paper_* folder is there); every part they need is "
                        "loaded and checked before the service listens")
    p.add_argument("--host", default="127.0.0.1", help="interface to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=int, default=8000, help="TCP port (default 8000)")
    p.add_argument("--max-batch", type=int, default=64, help="most act requests in one network call (default 64)")
    p.add_argument("--max-wait-ms", type=float, default=5.0,
                   help="how long the first waiting request waits for others to join its batch (default 5 ms)")
    p.add_argument("--max-queue", type=int, default=256, help="waiting requests beyond which new ones get 503 (default 256)")
    p.add_argument("--timeout", type=float, default=10.0,
                   help="seconds a request may wait for the planner before it gets 503 (default 10)")
    _planning_args(p)
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
    p.add_argument("--scene-seed", type=int, default=0, help="seed of the random scene (goals, target, start; default 0)")
    p.add_argument("--scenes", type=int, default=1,
                   help="run this many scenes, seeds SCENE_SEED, SCENE_SEED+1, ...; media for the first (default 1)")
    p.add_argument("--method", choices=list(ALL_PLANNERS), default="scdp", help="default scdp (style chosen per chunk)")
    p.add_argument("--camera", help="calibration JSON (default: the simulated cell's camera)")
    p.add_argument("--depth-noise", action="store_true", help="RealSense-like depth noise and holes")
    p.add_argument("--margin", type=float, default=0.9,
                   help="plan the 1 kHz motion within this fraction of the velocity/acceleration/jerk limits (default 0.9)")
    p.add_argument("--no-video", action="store_true", help="skip strip.png and deploy.mp4")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    _planning_args(p)
    p.set_defaults(handler="deploy:deploy")
    add_study_parsers(sub)
    return parser
