"""``scdp import-lerobot`` and ``scdp export-demos``: LeRobot v3 datasets in and out (pyarrow, the
``lerobot`` extra: without it, these commands say which extra to install)."""

from __future__ import annotations

from scdp.data import lerobot, lerobot_export
from scdp.data.dataset import DemoDataset
from scdp.io import check_output_path


def import_lerobot(args) -> int:
    check_output_path(args.out, force=args.force)
    dataset = lerobot.import_lerobot(args.path, args.task, state=args.state_feature, action=args.action_feature,
                                     goals=args.goals_feature, target=args.target_feature, goal_dim=args.goal_dim,
                                     action_from=args.action_from)
    dataset.save(args.out, force=args.force)
    print(f"wrote {args.out}: {dataset.num_episodes} demos, {dataset.num_steps} steps "
          f"(goals from {dataset.attrs['mapping']['goals']})")
    return 0


def export_demos(args) -> int:
    check_output_path(args.out, force=args.force)
    dataset = DemoDataset.load(args.demos)
    lerobot_export.export_lerobot(dataset, args.out, fps=args.fps, task_text=args.task_text, robot_type=args.robot_type,
                                  force=args.force)
    info = lerobot.read_info(args.out)
    print(f"wrote {args.out}: LeRobot {lerobot.CODEBASE_VERSION}, {dataset.num_episodes} episodes, "
          f"{dataset.num_steps} frames at {info['fps']:g} fps, robot_type {info['robot_type']!r}")
    return 0
