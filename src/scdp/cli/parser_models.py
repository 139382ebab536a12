"""The ``scdp`` models commands' arguments and help text (assembled by :mod:`scdp.cli.parser`).

Standard library and scdp's light leaves only, as the parser, so ``scdp --help`` stays instant.
"""

from __future__ import annotations

from scdp import planners
from scdp.cli.parser_common import device_arg, goals_arg, planning_args, set_arg, task_arg
from scdp.cli.types import point, seed
from scdp.keys import STYLE_MODES, STYLES


def add_model_parsers(sub) -> None:
    """``scdp train | plan | export``: train a part, plan one scene with the models, export their denoisers."""
    p = sub.add_parser("train", help="train one part: base, encoder, style, ld or student",
                       description="Train one part into its own checkpoint folder (model.safetensors + config.json). "
                       "Style predictors need a trained base and encoder (by default the sibling folders base/ and encoder/ of --out); "
                       "the few-step student (methods dp_student, scdp_student) needs those and both style predictors "
                       "beside the base (style_legible/, style_efficient/).")
    p.add_argument("part", choices=["base", "encoder", "style", "ld", "student"], help="which part")
    task_arg(p)
    p.add_argument("--data", help="demonstrations (.zarr); not needed for the encoder")
    p.add_argument("--out", help="checkpoint folder for this part, e.g. ckpt/base")
    p.add_argument("--preset", default="cpu", help="cpu (default), paper or tiny")
    set_arg(p)
    goals_arg(p, "the encoder's scenes; the same as --set data.goals=N; default the preset's, 2")
    p.add_argument("--style", choices=list(STYLES), default="legible", help="for part style (default legible)")
    p.add_argument("--design", choices=["scdp", "paper"], default="scdp",
                   help="for part style: the preset's style section (scdp, default) or the paper's design "
                        "(paper_style, for method scdp_paper; save it as style_paper_<style>)")
    p.add_argument("--base", help="for parts style and student, and ld with ld.init=base: base checkpoint folder "
                                  "(default OUT/../base)")
    p.add_argument("--encoder", help="for parts style and student: encoder checkpoint folder (default OUT/../encoder)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run from its last checkpoint")
    p.add_argument("--force", action="store_true", help="retrain over an existing checkpoint")
    p.add_argument("--dry-run", action="store_true", help="build the model only; print {part, parameters} as JSON")
    device_arg(p)
    p.set_defaults(handler="train:train")

    p = sub.add_parser("plan", help="roll out one scene with dp, ld or scdp and save the trajectory as JSON")
    task_arg(p)
    p.add_argument("--checkpoints", required=True, help="folder with base/, ld/, encoder/, style_legible/, style_efficient/")
    p.add_argument("--goals", type=point, nargs="+", required=True, help="goals as x,y (or x,y,z) ...")
    p.add_argument("--target", type=int, default=0, help="index of g* among --goals (default 0)")
    p.add_argument("--method", choices=list(planners.names()), default="scdp", help="default scdp")
    p.add_argument("--style", choices=list(STYLE_MODES), default=None,
                   help="scdp only: auto lets the ellipse of ambiguity choose per chunk (default); refused with a "
                        "method that has no style choice (dp, ld, ld_paper, scdp_paper) or fixes another one")
    p.add_argument("--seed", type=seed, default=0, help="seed of the sampler and start noise (default 0)")
    p.add_argument("--out", required=True, help="output .json")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    planning_args(p, "plan")
    p.set_defaults(handler="plan:plan")

    p = sub.add_parser("export", help="write each diffusion checkpoint's denoiser as ONNX, checked against torch",
                       description="Exports the denoiser of base/, ld/ and student/ in CHECKPOINTS (the U-Net with its style-film "
                                   "inputs) as model.onnx beside its weights, with onnx.json (opset, film layout, sampler, "
                                   "normalisation, parity). Each graph is compared with torch on random inputs before it is "
                                   "renamed into place; one off by more than 1e-4 is refused, naming the worst case.",
                       epilog="Then plan with it: scdp plan ... --runtime onnx (also evaluate, serve, deploy).")
    task_arg(p)
    p.add_argument("checkpoints", help="checkpoint folder holding base/ (and ld/, student/)")
    p.add_argument("--parts", nargs="+", metavar="PART", help="export only these parts (base, ld, student; default: every "
                                                                "one the folder holds), e.g. a student trained after the others")
    p.add_argument("--force", action="store_true", help="replace existing model.onnx / onnx.json")
    p.set_defaults(handler="export:export")

