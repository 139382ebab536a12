"""The ``scdp`` runs commands' arguments and help text (assembled by :mod:`scdp.cli.parser`).

Standard library and scdp's light leaves only, as the parser, so ``scdp --help`` stays instant.
"""

from __future__ import annotations

from scdp.cli.parser_common import TASK_HELP, device_arg, executor_args, goals_arg, planning_args, set_arg, task_arg
from scdp.cli.types import count, float_in, method_spec, seed
from scdp.config.planning import PlannerSpec
from scdp.keys import EVENT_KINDS, PROTOCOLS
from scdp.observers import CONFIDENCE


def _evaluate(sub) -> None:
    """``evaluate``: its arguments and help."""
    p = sub.add_parser("evaluate", help="roll out methods on random ambiguous and clear scenes (or one layout): mean "
                                        "metrics and paired differences against a baseline with 95 %% intervals",
                       description="Rolls out every method on the same scenes with the same noise: --scenes ambiguous and "
                                   "--scenes clear random scenes (labelled by eq. 3 at the start) of the evaluation stream "
                                   "for --seed, or one fixed layout. Prints each method's mean metrics per scene set and "
                                   "its paired differences against --baseline (T_fa, T, D̂, Ê, success) with 95 %% "
                                   "bootstrap intervals, under both normalisations of D̂ and Ê (per scene, and over the "
                                   "training demonstrations, --demos). A new --seed gives scenes nobody has looked at.")
    task_arg(p)
    p.add_argument("--checkpoints", required=True, help="checkpoint folder (see plan)")
    p.add_argument("--encoder", help="scene encoder folder, if not CHECKPOINTS/encoder (per-layout model sets)")
    p.add_argument("--demos", help="the demos the models learned from (a demos.zarr), for the reading of D̂, Ê and ĵ over "
                                   "the training data (default: demos.zarr beside CHECKPOINTS, when there; else per scene only)")
    p.add_argument("--methods", nargs="+", type=method_spec,
                   default=[PlannerSpec.parse(m) for m in ("dp", "ld", "scdp", "scdp_legible", "scdp_efficient")],
                   help="planners by name (dp, ld, ld_paper, scdp, scdp_paper, scdp_blend, ...) or scdp:<style> "
                        "(default: dp ld scdp scdp_legible scdp_efficient)")
    p.add_argument("--baseline", help="the method every other one is compared with (default dp, when evaluated)")
    p.add_argument("--scenes", type=count, default=50,
                   help="random scenes per set (ambiguous, clear), or rollouts of --layout (default 50)")
    p.add_argument("--layout", type=int, metavar="K",
                   help="roll out on the authors' layout K (1..6), the two targets in turn, instead of random scenes")
    p.add_argument("--events", choices=EVENT_KINDS, metavar="FAMILY",
                   help="scenes that change during the motion instead: appear (a distractor is put down near the "
                        "target), vanish (it is taken away) or move (the target moves); --scenes of them, measured "
                        "after the event (scdp.evaluation.dynamic)")
    p.add_argument("--seed", type=seed, default=1, help="seed of scenes and sampling (default 1)")
    goals_arg(p, "default: the scene encoder's count when an SCDP method is evaluated, else 2; not with --layout")
    p.add_argument("--out", help="write the summary JSON here")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    planning_args(p, "evaluate")
    p.set_defaults(handler="evaluate:evaluate")


def _reproduce(sub) -> None:
    """``reproduce``: its arguments and help."""
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
    p.add_argument("--task", default="all", help=f"all (default: the paper's two tasks), or one: {TASK_HELP}")
    p.add_argument("--preset", default="cpu", help="cpu (default), paper, or tiny (a smoke test)")
    set_arg(p)
    p.add_argument("--out", default="runs/cpu", help="output folder (default runs/cpu)")
    p.add_argument("--protocol", default="random", choices=list(PROTOCOLS),
                   help="random-scene models (default), the authors' per-layout models, or both")
    p.add_argument("--layouts", type=int, nargs="+", metavar="K",
                   help="per-layout protocol: only these layouts (1..6; default all six)")
    goals_arg(p, "demos, encoder and evaluation scenes; the same as --set data.goals=N; default 2, the paper's, "
                  "with the six layouts, which more goals leave out")
    seeds = p.add_mutually_exclusive_group()
    seeds.add_argument("--seed", type=seed, default=0,
                       help="training seed of every part (weight initialisation, shuffling, noise; default 0). "
                            "Demos and evaluation scenes keep their own seeds, so seeds compare the same scenes "
                            "(add --set data.seed=K for demos of their own)")
    seeds.add_argument("--seeds", type=seed, nargs="+", metavar="K",
                       help="one whole reproduction per training seed, each in OUT/seed_K (the confirmation's three "
                            "seeds: --seeds 0 1 2); their units run side by side under --executor ray")
    executor_args(p, "every independent unit (each seed and task's shared stages, then each model set, then each "
                     "evaluation)")
    p.add_argument("--adopt", action="store_true",
                   help="outputs whose record predates some of today's inputs (a run made before scdp recorded them): "
                        "take them as made from today's values of those inputs, where every input they did record "
                        "agrees, and record that, instead of redoing them. Only for a run you know is consistent")
    p.add_argument("--dry-run", action="store_true",
                   help="print each stage the run would redo and the inputs that changed, then stop: nothing is "
                        "trained, rolled out or written (exit 0 whether or not the run is current)")
    device_arg(p)
    p.set_defaults(handler="reproduce:reproduce")


def _verify(sub) -> None:
    """``verify``: its arguments and help."""
    p = sub.add_parser("verify", help="does your own trained run support the committed verdicts? (fresh scenes, side by side)",
                       description="Rolls out a reproduction's models (RUN/<task>/checkpoints, e.g. trained on your machine) "
                                   "with the committed run's preset on fresh random scenes of an evaluation seed neither run "
                                   "reported, judges the paper's claims, the style-effect and the observer targets with their 95 %% "
                                   "intervals, and prints each verdict beside the committed one. Weights trained on another "
                                   "processor differ in their last bits and beyond; the verdicts are what should agree.",
                       epilog="Example: scdp reproduce --preset cpu --out runs/mine && scdp verify runs/mine --against results/cpu")
    p.add_argument("run", help="the reproduction folder to check (its <task>/checkpoints)")
    p.add_argument("--against", default="results/cpu", help="the committed run (claims.json, results.json; default %(default)s)")
    p.add_argument("--scenes", type=count, default=50,
                   help="fresh ambiguous and clear scenes each, per task (default %(default)s: a few minutes for the cpu preset)")
    p.add_argument("--seed", type=seed, default=1234, help="their evaluation seed (default %(default)s, which no committed result reports)")
    p.add_argument("--out", help="also write the comparison here as JSON (never over a file without --force)")
    p.add_argument("--force", action="store_true", help="replace --out")
    device_arg(p)
    p.set_defaults(handler="verify:verify")


def _report(sub) -> None:
    """``report``: its arguments and help."""
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
    p.add_argument("--confidence", type=float_in(0.5, 1, hi_open=True), default=CONFIDENCE, metavar="P",
                   help="the observer is confident once P(g* | path so far) stays at or above P to the end "
                        "(time to confidence; 0.5 <= P < 1, above one half the target outweighs every other goal together; "
                        "default %(default)s, as in the report of scdp reproduce)")
    p.add_argument("--force", action="store_true", help="replace existing report files")
    p.set_defaults(handler="reproduce:report")


def add_run_parsers(sub) -> None:
    """``scdp evaluate | reproduce | verify | report``: runs over many scenes and their reports."""
    for add in (_evaluate, _reproduce, _verify, _report):
        add(sub)

