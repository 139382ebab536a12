"""``scdp evaluate``: methods on random scenes (or one layout), mean normalised metrics."""

from __future__ import annotations

from scdp.data.scenes import check_layout, layout_scenes, sample_scenes
from scdp.errors import ScdpError
from scdp.evaluation.protocol import evaluate_methods
from scdp.evaluation.records import summarize
from scdp.io import check_output_path, write_json
from scdp.policies.loaders import load_method
from scdp.tasks import get_task


def evaluate(args) -> int:
    task = get_task(args.task)
    if args.out:
        check_output_path(args.out, force=args.force)
    if args.scenes < 1:
        raise ScdpError("--scenes", f"must be at least 1, got {args.scenes}")
    if args.layout is None:
        scenes, scene_set = sample_scenes(task, args.scenes, args.seed), "random"
    else:
        k = check_layout(args.layout, "--layout")
        scenes, scene_set = layout_scenes(task, k, (args.scenes + 1) // 2)[:args.scenes], f"layout_{k}"
    planners = {}
    for spec in args.methods:
        method, _, style = spec.partition(":")
        planners[spec] = load_method(args.checkpoints, task, method, style or None, encoder_dir=args.encoder,
                                     sampler=args.sampler, steps=args.steps, device=args.device)
    records = evaluate_methods(task, planners, {scene_set: scenes}, seed=args.seed)
    results = {"command": args.command_line, "task": task.name, "scene_set": scene_set, "scenes": args.scenes, "seed": args.seed,
               "runs": {}}
    for spec in args.methods:
        mine = [r for r in records if r.method == spec]
        s = results["runs"][spec] = summarize(mine)
        print(f"{spec:16s} success {s['success']['mean']:.2f}  d_hat {s['d_hat']['mean']:.3f}±{s['d_hat']['std']:.3f}  "
              f"e_hat {s['e_hat']['mean']:.3f}±{s['e_hat']['std']:.3f}  T {s['transparency']['mean']:.3f}  "
              f"legibility(beta={mine[0].beta:g}) {s['legibility']['mean']:.3f}  {s['seconds']['mean']:.2f} s/traj")
    if args.out:
        write_json(args.out, results)
    return 0
