"""The ``scdp`` command line. Run ``scdp --help`` or ``scdp <command> --help``.

Every command validates its input first; a bad value is reported as one line
``scdp: error: <field>: <problem>`` with exit status 2, and nothing is written.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from pathlib import Path

from scdp.errors import ScdpError

EXIT_BAD_INPUT = 2
# scdp.data.generate.SCENE_MODES, spelled out so that `--help` needs no heavy imports
SCENE_MODES = ["random", "fixed", *(f"config_{i}" for i in range(1, 7))]


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line naming the argument."""

    def error(self, message):
        match = re.match(r"argument ([^:]+): (.*)", message)
        if match:
            raise ScdpError(match.group(1), match.group(2))
        raise ScdpError(self.prog, message)


def _point(text: str):
    try:
        return [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers like 1.5,0.2, got {text!r}") from None


def _task_arg(p, **kw):
    p.add_argument("--task", required=True, help="navigation or block_reach", **kw)


# -- commands ------------------------------------------------------------------------------------


def cmd_generate(args) -> int:
    from scdp.data.generate import generate_demos
    from scdp.io import check_output_path
    from scdp.tasks import get_task

    task = get_task(args.task)
    check_output_path(args.out, force=args.force)
    t0 = time.perf_counter()
    dataset, report = generate_demos(task, args.num_demos, args.seed, scenes=args.scenes)
    dataset.attrs["generation_seconds"] = time.perf_counter() - t0
    dataset.save(args.out, force=args.force)
    print(f"wrote {args.out}: {report['demos']} demos ({report['failures']} failed and were redrawn), "
          f"lengths {report['length_min']}-{report['length_max']}, {time.perf_counter() - t0:.1f} s")
    return 0


def cmd_inspect(args) -> int:
    from scdp.data.dataset import DemoDataset

    print(json.dumps(inspect_dataset(DemoDataset.load(args.path)), indent=2))
    return 0


def inspect_dataset(dataset) -> dict:
    """Counts, lengths and the spread of path curvature of a dataset."""
    import numpy as np

    from scdp.data.bezier import signed_bend
    from scdp.tasks import get_task

    task = get_task(dataset.task)
    lengths = dataset.episode_lengths()
    bends = np.array([signed_bend(task.episode_path(dataset.episode(i))) for i in range(dataset.num_episodes)])
    q = [0, 10, 25, 50, 75, 90, 100]
    return {
        "task": dataset.task,
        "episodes": int(dataset.num_episodes),
        "steps": int(dataset.num_steps),
        "length": {"min": int(lengths.min()), "mean": round(float(lengths.mean()), 1), "max": int(lengths.max())},
        "bend_percentiles": {f"p{k}": round(float(v), 3) for k, v in zip(q, np.percentile(bends, q))},
        "bend_abs_mean": round(float(np.abs(bends).mean()), 3),
        "left_right": [int(np.sum(bends > 0)), int(np.sum(bends < 0))],
        "goals_per_scene": int(dataset.goals.shape[1]),
        "seed": dataset.attrs.get("seed"),
    }


def cmd_plot_demos(args) -> int:
    from scdp.data.dataset import DemoDataset
    from scdp.io import check_output_path
    from scdp.plotting import plot_demos, save_figure
    from scdp.tasks import get_task

    check_output_path(args.out, force=True)
    dataset = DemoDataset.load(args.path)
    save_figure(plot_demos(dataset, get_task(dataset.task), args.max_demos), args.out)
    print(f"wrote {args.out}")
    return 0


def cmd_import_hdf5(args) -> int:
    from scdp.data.robomimic import import_robomimic
    from scdp.io import check_output_path

    check_output_path(args.out, force=args.force)
    dataset = import_robomimic(args.path, args.task)
    dataset.save(args.out, force=args.force)
    print(f"wrote {args.out}: {dataset.num_episodes} demos, {dataset.num_steps} steps")
    return 0


def cmd_ambiguity_report(args) -> int:
    from scdp.ambiguity import ambiguity_report, report_markdown
    from scdp.io import check_output_path, write_json, write_text

    out = Path(args.out) if args.out else None
    if out:
        check_output_path(out, force=True)
    report = ambiguity_report(args.task, n_random=args.scenes, seed=args.seed)
    text = report_markdown(report)
    if out:
        write_json(out, report)
        write_text(out.with_suffix(".md"), text)
    print(text)
    return 0


def cmd_plot_ellipse(args) -> int:
    from scdp.io import check_output_path
    from scdp.plotting import plot_ellipse, save_figure
    from scdp.tasks import get_task

    task = get_task(args.task)
    check_output_path(args.out, force=True)
    goals = task.validate_goals(args.goals, args.target)
    save_figure(plot_ellipse(task, goals, args.target), args.out)
    print(f"wrote {args.out}")
    return 0


def cmd_train(args) -> int:
    from scdp.config import get_preset
    from scdp.tasks import get_task
    from scdp.training import parts

    task, preset = get_task(args.task), get_preset(args.preset)
    if args.dry_run:
        print(json.dumps(parts.dry_run(task, preset, args.part)))
        return 0
    if not args.out:
        raise ScdpError("--out", "required unless --dry-run")
    out = Path(args.out)
    if (out / "config.json").exists() and not (args.resume or args.force):
        raise ScdpError("--out", f"{out} already holds a checkpoint (pass --resume to continue or --force to retrain)")
    if args.part == "encoder":
        _, result = parts.train_encoder(task, preset, out, resume=args.resume)
    else:
        from scdp.data.dataset import DemoDataset

        if not args.data:
            raise ScdpError("--data", f"training {args.part} needs demonstrations")
        dataset = DemoDataset.load(args.data)
        if args.part in ("base", "ld"):
            _, result = parts.train_diffusion(task, dataset, preset, out, ld=args.part == "ld", resume=args.resume)
        else:
            base = Path(args.base) if args.base else out.parent / "base"
            encoder = Path(args.encoder) if args.encoder else out.parent / "encoder"
            _, result = parts.train_style(task, dataset, args.style, preset, base, encoder, out, resume=args.resume)
    print(f"trained {args.part} for {result.steps} steps (final epoch loss {result.losses[-1]:.5f}) -> {out}")
    return 0


def cmd_plan(args) -> int:
    import numpy as np

    from scdp.evaluation.evaluate import scene_bounds, trajectory_record
    from scdp.evaluation.rollout import rollout
    from scdp.io import check_output_path, write_json
    from scdp.policies.checkpoint import load_method
    from scdp.tasks import get_task

    task = get_task(args.task)
    check_output_path(args.out, force=True)
    goals = task.validate_goals(args.goals, args.target)
    planner = load_method(args.checkpoints, task, args.method, args.style)
    encoder = getattr(planner, "encoder", None)
    if encoder is not None and encoder.config.n_goals != len(goals):
        raise ScdpError("--goals", f"the scene encoder was trained for {encoder.config.n_goals} goals, got {len(goals)}")
    t0 = time.perf_counter()
    (run,) = rollout(task, planner, [(goals, args.target)], seed=args.seed)
    wall = time.perf_counter() - t0
    record = trajectory_record(task, run, method=args.method, scene_set="custom", bounds=scene_bounds(task, goals, args.target))
    record.update(states=np.asarray(run.states).round(6).tolist(), actions=np.asarray(run.actions).round(6).tolist(),
                  planning_seconds=run.seconds, wall_seconds=wall, seed=args.seed)
    write_json(args.out, record)
    m = record["metrics"]
    print(f"{args.method}: success={run.success} steps={len(run.actions)} styles={_runs(run.styles)} "
          f"d_hat={m['d_hat']:.3f} e_hat={m['e_hat']:.3f} T={m['transparency']:.3f} "
          f"planning={run.seconds:.2f}s -> {args.out}")
    return 0


def _runs(styles: list[str]) -> str:
    """'legible x2, efficient x9': the style of consecutive chunks, run-length encoded."""
    out: list[list] = []
    for s in styles:
        if out and out[-1][0] == s:
            out[-1][1] += 1
        else:
            out.append([s, 1])
    return ", ".join(f"{s} x{n}" for s, n in out)


def cmd_evaluate(args) -> int:
    from scdp.evaluation.evaluate import random_scenes, scene_bounds, summarize, trajectory_record
    from scdp.evaluation.rollout import rollout
    from scdp.io import check_output_path, write_json
    from scdp.policies.checkpoint import load_method
    from scdp.tasks import get_task

    task = get_task(args.task)
    if args.out:
        check_output_path(args.out, force=True)
    if args.scenes < 1:
        raise ScdpError("--scenes", f"must be at least 1, got {args.scenes}")
    if args.config is None:
        scenes, scene_set = random_scenes(task, args.scenes, args.seed), "random"
    else:
        from scdp.evaluation.protocol import config_scenes

        if args.config not in range(1, len(task.fixed_configs) + 1):
            raise ScdpError("--config", f"configurations are numbered 1..{len(task.fixed_configs)}, got {args.config}")
        scenes, scene_set = config_scenes(task, args.config, (args.scenes + 1) // 2)[:args.scenes], f"config_{args.config}"
    cache: dict = {}
    results = {"command": args.command_line, "task": task.name, "scene_set": scene_set, "scenes": args.scenes, "seed": args.seed,
               "runs": {}}
    for spec in args.methods:
        method, _, style = spec.partition(":")
        planner = load_method(args.checkpoints, task, method, style or "auto", encoder_dir=args.encoder)
        runs = rollout(task, planner, scenes, seed=args.seed, progress=True, desc=f"{task.name} {spec}")
        records = [trajectory_record(task, r, method=method, scene_set=scene_set, bounds=scene_bounds(task, r.goals, r.target, cache))
                   for r in runs]
        results["runs"][spec] = summarize(records)
        s = results["runs"][spec]
        print(f"{spec:16s} success {s['success']['mean']:.2f}  d_hat {s['d_hat']['mean']:.3f}±{s['d_hat']['std']:.3f}  "
              f"e_hat {s['e_hat']['mean']:.3f}±{s['e_hat']['std']:.3f}  T {s['transparency']['mean']:.3f}  "
              f"legibility(beta={records[0]['beta']:g}) {s['legibility']['mean']:.3f}  {s['seconds']['mean']:.2f} s/traj")
    if args.out:
        write_json(args.out, results)
    return 0


def cmd_reproduce(args) -> int:
    from scdp.pipeline import reproduce

    reproduce(args.task, args.preset, args.out, protocol=args.protocol, configs=args.configs, command=args.command_line)
    return 0


# -- parser ---------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="scdp",
        description="Style-Conditioned Diffusion Policy: demonstrations, metrics, ambiguity and the paper's reproduction.",
        epilog="Start with `scdp reproduce --task navigation --preset cpu --out runs/cpu`, "
        "or `scdp generate --task navigation --num-demos 200 --seed 0 --out demos.zarr`.",
    )
    sub = parser.add_subparsers(dest="command", metavar="<command>", parser_class=_Parser)

    p = sub.add_parser("generate", help="generate Bézier demonstrations in simulation into a zarr replay buffer",
                       description="Draw quadratic Bézier paths, execute them in the task's simulator, and store the successful ones.")
    _task_arg(p)
    p.add_argument("--num-demos", type=int, default=200, help="number of successful demos (default 200)")
    p.add_argument("--seed", type=int, default=0, help="seed of every random draw (default 0)")
    p.add_argument("--scenes", choices=SCENE_MODES, default="random", metavar="{random,fixed,config_1..config_6}",
                   help="random goals per demo (default), the authors' six fixed configurations in turn, "
                        "or one of them only (config_k, as in the per-configuration protocol)")
    p.add_argument("--out", required=True, help="output .zarr folder")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(func=cmd_generate)

    p = sub.add_parser("inspect", help="print counts, lengths and curvature spread of a dataset")
    p.add_argument("path", help="a .zarr dataset")
    p.set_defaults(func=cmd_inspect)

    p = sub.add_parser("plot-demos", help="draw a dataset's paths over their scenes")
    p.add_argument("path", help="a .zarr dataset")
    p.add_argument("--out", required=True, help="image file (.png or .pdf)")
    p.add_argument("--max-demos", type=int, default=50, help="how many demos to draw (default 50)")
    p.set_defaults(func=cmd_plot_demos)

    p = sub.add_parser("import-hdf5", help="import robomimic-style HDF5 demonstrations into zarr")
    p.add_argument("path", help="HDF5 file with data/demo_k/{states, actions, obs/object}")
    _task_arg(p)
    p.add_argument("--out", required=True, help="output .zarr folder")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(func=cmd_import_hdf5)

    p = sub.add_parser("ambiguity-report", help="calibrate ambiguity and compare the ellipse with eq. 3 on random scenes")
    _task_arg(p)
    p.add_argument("--scenes", type=int, default=10_000, help="random scenes to compare on (default 10000)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random scenes (default 0)")
    p.add_argument("--out", help="write the report as JSON here (and Markdown beside it)")
    p.set_defaults(func=cmd_ambiguity_report)

    p = sub.add_parser("plot-ellipse", help="draw the ellipse of ambiguity for one scene (the paper's Fig. 4b)")
    _task_arg(p)
    p.add_argument("--goals", type=_point, nargs="+", required=True, help="goals as x,y (or x,y,z) ...")
    p.add_argument("--target", type=int, default=0, help="index of g* among --goals (default 0)")
    p.add_argument("--out", required=True, help="image file (.png or .pdf)")
    p.set_defaults(func=cmd_plot_ellipse)

    p = sub.add_parser("train", help="train one part: base, encoder, style or ld",
                       description="Train one part into its own checkpoint folder (model.safetensors + config.json). "
                       "Style predictors need a trained base and encoder (by default the sibling folders base/ and encoder/ of --out).")
    p.add_argument("part", choices=["base", "encoder", "style", "ld"], help="which part")
    _task_arg(p)
    p.add_argument("--data", help="demonstrations (.zarr); not needed for the encoder")
    p.add_argument("--out", help="checkpoint folder for this part, e.g. ckpt/base")
    p.add_argument("--preset", default="cpu", help="cpu (default), paper or tiny")
    p.add_argument("--style", choices=["legible", "efficient"], default="legible", help="for part style (default legible)")
    p.add_argument("--base", help="for part style: base checkpoint folder (default OUT/../base)")
    p.add_argument("--encoder", help="for part style: encoder checkpoint folder (default OUT/../encoder)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run from its last checkpoint")
    p.add_argument("--force", action="store_true", help="retrain over an existing checkpoint")
    p.add_argument("--dry-run", action="store_true", help="build the model only; print {part, parameters} as JSON")
    p.set_defaults(func=cmd_train)

    p = sub.add_parser("plan", help="roll out one scene with dp, ld or scdp and save the trajectory as JSON")
    _task_arg(p)
    p.add_argument("--checkpoints", required=True, help="folder with base/, ld/, encoder/, style_legible/, style_efficient/")
    p.add_argument("--goals", type=_point, nargs="+", required=True, help="goals as x,y (or x,y,z) ...")
    p.add_argument("--target", type=int, default=0, help="index of g* among --goals (default 0)")
    p.add_argument("--method", choices=["dp", "ld", "scdp"], default="scdp", help="default scdp")
    p.add_argument("--style", choices=["auto", "legible", "efficient", "none"], default="auto",
                   help="scdp only: auto lets the ellipse of ambiguity choose per chunk (default)")
    p.add_argument("--seed", type=int, default=0, help="seed of the sampler and start noise (default 0)")
    p.add_argument("--out", required=True, help="output .json")
    p.set_defaults(func=cmd_plan)

    p = sub.add_parser("evaluate", help="roll out methods on random scenes (or one fixed configuration) and print mean normalised metrics")
    _task_arg(p)
    p.add_argument("--checkpoints", required=True, help="checkpoint folder (see plan)")
    p.add_argument("--encoder", help="scene encoder folder, if not CHECKPOINTS/encoder (per-configuration model sets)")
    p.add_argument("--methods", nargs="+", default=["dp", "scdp:legible", "scdp:efficient"],
                   help="dp, ld, scdp or scdp:<style> (default: dp scdp:legible scdp:efficient)")
    p.add_argument("--scenes", type=int, default=50, help="random scenes, or rollouts of --config (default 50)")
    p.add_argument("--config", type=int, metavar="K",
                   help="roll out on the authors' configuration K (1..6), the two targets in turn, instead of random scenes")
    p.add_argument("--seed", type=int, default=1, help="seed of scenes and sampling (default 1)")
    p.add_argument("--out", help="write the summary JSON here")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("reproduce", help="the main job: run every stage of the paper's reproduction",
                       description="Runs the reproduction stages in order, skipping those whose output is already valid "
                                   "(and newer than what it was made from), so a killed run resumes where it stopped. "
                                   "Writes results.json, tables, figures, claims.json and report.md into --out.",
                       epilog="Protocols: 'random' trains one model set per task on demos of random scenes and evaluates it on "
                              "random ambiguous / non-ambiguous scenes and the six fixed configurations. 'per_config' is the "
                              "authors' protocol: one model set per fixed configuration, trained on demos of that configuration "
                              "only and evaluated on it. 'both' runs the two and reports them side by side (Table 3).")
    p.add_argument("--task", default="all", choices=["navigation", "block_reach", "all"], help="default all")
    p.add_argument("--preset", default="cpu", help="cpu (default), paper, or tiny (a smoke test)")
    p.add_argument("--out", default="runs/cpu", help="output folder (default runs/cpu)")
    p.add_argument("--protocol", default="random", choices=["random", "per_config", "both"],
                   help="random-scene models (default), the authors' per-configuration models, or both")
    p.add_argument("--configs", type=int, nargs="+", metavar="K",
                   help="per-configuration protocol: only these configurations (1..6; default all six)")
    p.set_defaults(func=cmd_reproduce)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    try:
        argv = sys.argv[1:] if argv is None else list(argv)
        args = parser.parse_args(argv)
        args.command_line = " ".join(["scdp", *argv])
        if not getattr(args, "func", None):
            parser.print_help()
            return EXIT_BAD_INPUT
        for name in ("num_demos", "scenes", "max_demos"):
            value = getattr(args, name, None)
            if isinstance(value, int) and value < 0:
                raise ScdpError("--" + name.replace("_", "-"), f"must be >= 0, got {value}")
        return args.func(args)
    except ScdpError as exc:
        print(f"scdp: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # disk full, permissions changed mid-run, ...
        print(f"scdp: error: {getattr(exc, 'filename', None) or 'io'}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("scdp: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
