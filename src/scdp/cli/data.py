"""``scdp generate``, ``inspect``, ``plot-demos`` and ``import-hdf5``: demonstrations."""

from __future__ import annotations

import json
import sys
import time

from scdp.data.dataset import DemoDataset
from scdp.data.generate import generate_demos
from scdp.data.robomimic import import_robomimic
from scdp.data.scenes import check_goal_count
from scdp.data.stats import dataset_stats
from scdp.evaluation.figures import plot_demos as draw_demos
from scdp.evaluation.figures import save_figure
from scdp.io import check_output_path
from scdp.tasks import get_task


def generate(args) -> int:
    task = get_task(args.task)
    check_output_path(args.out, force=args.force)
    t0 = time.perf_counter()
    n_goals = 2 if args.goals is None else check_goal_count(args.goals, args.scenes, "--goals")
    dataset, report = generate_demos(task, args.num_demos, args.seed, scenes=args.scenes, n_goals=n_goals,
                                     turning=args.turning, turn_from=args.turn_from)
    dataset.attrs["generation_seconds"] = time.perf_counter() - t0
    dataset.save(args.out, force=args.force)
    print(f"wrote {args.out}: {report['demos']} demos ({report['failures']} failed and were redrawn), "
          f"lengths {report['length_min']}-{report['length_max']}, {time.perf_counter() - t0:.1f} s")
    for warning in report["warnings"]:
        print(f"scdp: warning: generate: {warning}", file=sys.stderr)
    return 0


def inspect(args) -> int:
    print(json.dumps(dataset_stats(DemoDataset.load(args.path)), indent=2))
    return 0


def plot_demos(args) -> int:
    check_output_path(args.out, force=args.force)
    dataset = DemoDataset.load(args.path)
    save_figure(draw_demos(dataset, dataset.task_object(), args.max_demos), args.out)
    print(f"wrote {args.out}")
    return 0


def import_hdf5(args) -> int:
    check_output_path(args.out, force=args.force)
    dataset = import_robomimic(args.path, args.task, goal_dim=args.goal_dim)
    if dataset.attrs["dropped_steps"]:
        print(f"scdp: warning: dropped {dataset.attrs['dropped_steps']} step(s) from the end of "
              f"{dataset.attrs['demos_with_dropped_steps']} demo(s): after 'dones', or actions beyond the robot's one-step reach",
              file=sys.stderr)
    dataset.save(args.out, force=args.force)
    print(f"wrote {args.out}: {dataset.num_episodes} demos, {dataset.num_steps} steps")
    return 0
