"""``scdp evaluate``: methods on random ambiguous and clear scenes (or one layout), their mean
metrics, and paired differences against a baseline with 95 % bootstrap intervals."""

from __future__ import annotations

import time
from pathlib import Path

from scdp.config import PlanningOptions
from scdp.data.dataset import DemoDataset
from scdp.data.scenes import check_goal_count, check_layout, layout_scenes
from scdp.errors import ScdpError, refuse_repeats
from scdp.evaluation.dynamic import EVENT_FRACTION, evaluate_events
from scdp.evaluation.normalised import under
from scdp.evaluation.protocol import evaluate_methods, scene_sets
from scdp.evaluation.records import early_failures, summarize
from scdp.evaluation.statistics import PairedDifference, compare
from scdp.io import check_output_path, write_json
from scdp.keys import AMBIGUOUS, CLEAR, DATASET_NORMALISATION, RANDOM, SCENE_NORMALISATION, layout_name
from scdp.policies.base import check_scene_goals, trained_goal_count
from scdp.policies.loaders import load_method
from scdp.scoring import NORMALISATION_NAMES, dataset_range
from scdp.tasks import Task, get_task

DIFFERENCE_METRICS = ("transparency_fa", "transparency", "d_hat", "e_hat", "success")


def _scenes(task: Task, args, n_goals: int) -> dict:
    """``--scenes`` ambiguous + ``--scenes`` clear scenes of ``n_goals`` goals from the evaluation
    stream, or one layout's rollouts."""
    if args.layout is None:
        sets = scene_sets(task, args.scenes, args.seed, n_goals=n_goals)
        return {k: v for k, v in sets.items() if k in (AMBIGUOUS, CLEAR)}
    k = check_layout(args.layout, "--layout")
    return {layout_name(k): layout_scenes(task, k, (args.scenes + 1) // 2)[:args.scenes]}


def training_range(task: Task, args):
    """The range of D, E and j over ``--demos`` (default: demos.zarr beside the checkpoints), or None
    when no demos are named and none lie there."""
    demos = Path(args.demos) if args.demos else Path(args.checkpoints).parent / "demos.zarr"
    if not demos.exists():
        if args.demos:
            raise ScdpError("--demos", f"{demos} does not exist")
        return None
    dataset = DemoDataset.load(demos)
    if dataset.task != task.name:
        raise ScdpError("--demos", f"{demos} holds demos of {dataset.task!r}, not of {task.name!r}")
    return dataset_range(task, dataset)


def evaluate_event_family(task: Task, planners: dict, baseline: str | None, args) -> int:
    """``--events FAMILY``: the planners on scenes that change during the motion, measured after the event."""
    started = time.perf_counter()
    result = evaluate_events(task, planners, args.events, args.scenes, args.seed, baseline=baseline, progress=True)
    result["compute_minutes"] = round((time.perf_counter() - started) / 60, 2)
    result["command"] = args.command_line
    print(f"\n{task.name}, {args.events} scenes ({args.scenes}; the event after {EVENT_FRACTION:.0%} of a straight line):")
    for label, s in result["methods"].items():
        m = s["mean"]
        print(f"  {label:16s} success {m['success']:.2f}  switch latency {m['latency']:.2f} chunks  "
              f"switched within 2 {s['switched_within_2']:.2f}  legible after {m['post_legible']:.2f}  "
              f"observer after {m['observer']:.3f}")
    for d in map(PairedDifference.from_row, result["differences"]):
        print(f"    {d.a} − {d.b}: {d.metric} {d.cell()}{'*' if d.holds('>') or d.holds('<') else ''}")
    print(f"({result['compute_minutes']:.1f} compute-min; latency: chunks from the event to the first in the new "
          "scene's style, NaN for planners without styles)")
    if args.out:
        write_json(args.out, result, compact=True)  # every rollout's path: bulk data
    return 0


def _checked_methods(args) -> tuple[dict, list[str], str | None]:
    """(specs by label, labels in order, the baseline or None), every refusal made before a model loads."""
    if args.out:
        check_output_path(args.out, force=args.force)
    specs = {spec.label: spec for spec in args.methods}  # parsed by the parser (scdp.config.PlannerSpec)
    labels = [spec.label for spec in args.methods]
    refuse_repeats(labels, "--methods", same=specs.get)  # dp dp, or scdp_legible and scdp:legible
    baseline = args.baseline or ("dp" if "dp" in labels else None)  # None: no paired differences
    if baseline is not None and baseline not in labels:
        raise ScdpError("--baseline", f"{baseline!r} is not among --methods ({' '.join(labels)})")
    if args.goals is not None:
        check_goal_count(args.goals, RANDOM if args.layout is None else layout_name(args.layout), "--goals")
    if args.layout is not None:
        check_layout(args.layout, "--layout")  # a bad --layout is refused before any model loads
    if args.events and (args.layout is not None or (args.goals or 2) != 2):
        raise ScdpError("--events", "event families are two-goal random scenes: not with --layout or --goals other than 2")
    return specs, labels, baseline


def _differences(readings: dict, scene_set: str, labels: list[str], baseline: str) -> list[dict]:
    """Each method against the baseline on one scene set, under each normalisation: printed, and returned as rows."""
    out = []
    for name, read in readings.items():
        print(f"  paired differences, D̂ and Ê {NORMALISATION_NAMES[name]}:")
        group = [r for r in read if r.scene_set == scene_set]
        for label in (m for m in labels if m != baseline):
            diffs = [compare(group, label, baseline, m) for m in DIFFERENCE_METRICS]
            out += [d.row(scene_set=scene_set, normalisation=name) for d in diffs]
            cells = "  ".join(f"{d.metric} {d.cell()}{'*' if d.holds('>') or d.holds('<') else ' '}" for d in diffs)
            print(f"    {label} − {baseline}: {cells}")
    return out


def evaluate(args) -> int:
    task = get_task(args.task)
    specs, labels, baseline = _checked_methods(args)
    planning = PlanningOptions.from_args(args)
    planners = {label: load_method(spec, args.checkpoints, task, planning, encoder_dir=args.encoder)
                for label, spec in specs.items()}
    trained = trained_goal_count(planners.values())
    n_goals = args.goals or trained or 2
    check_scene_goals(trained, n_goals, "--goals")
    if args.layout is not None:  # the layouts hold two goals: an encoder of more cannot read them
        check_goal_count(n_goals, layout_name(args.layout), "--layout")
    if args.events:
        return evaluate_event_family(task, planners, baseline, args)
    rng = training_range(task, args)  # refused before any rollout
    sets = _scenes(task, args, n_goals)
    records = evaluate_methods(task, planners, sets, seed=args.seed)
    readings = {SCENE_NORMALISATION: records}
    if rng is not None:
        readings[DATASET_NORMALISATION] = under(records, DATASET_NORMALISATION, {task.name: rng})
    results = {"command": args.command_line, "task": task.name, "scenes_per_set": args.scenes, "seed": args.seed, "goals": n_goals,
               "baseline": baseline, "runs": {}, "differences": [],
               "normalisation_range": None if rng is None else rng.to_dict()}
    for scene_set in sets:
        print(f"\n{task.name}, {scene_set} scenes ({len(sets[scene_set])}):")
        group = [r for r in records if r.scene_set == scene_set]
        for label in labels:
            mine = [r for r in group if r.method == label]
            s = results["runs"].setdefault(scene_set, {})[label] = summarize(mine)
            print(f"  {label:16s} success {s['success']['mean']:.2f}  T {s['transparency']['mean']:.3f}  "
                  f"T_fa {s['transparency_fa']['mean']:.3f}  d_hat {s['d_hat']['mean']:.3f}  e_hat {s['e_hat']['mean']:.3f}  "
                  f"legibility(beta={mine[0].beta:g}) {s['legibility']['mean']:.3f}  {s['seconds']['mean']:.2f} s/traj")
            ended = early_failures(mine).get(label, [])
            if ended:  # a rollout that left the bounds failed alone; the rest went on
                s["ended_early"] = ended
                print(f"  {'':16s} {len(ended)} of {len(mine)} rollouts ended early as failures: {ended[0]}"
                      + (f" (and {len(ended) - 1} more, {'in --out' if args.out else 'listed with --out'})"
                         if len(ended) > 1 else ""))
        if baseline:
            results["differences"] += _differences(readings, scene_set, labels, baseline)
    print("\n(paired differences on the same scenes and noise, 95 % bootstrap intervals; * excludes zero; "
          "T_fa: T with a failed run scoring at most 0; the means above are per scene; success and legibility do "
          "not depend on the normalisation)")
    if rng is None:
        print("(the reading over the training data needs the demos the models learned from: --demos)")
    if args.out:
        write_json(args.out, results)
    return 0
