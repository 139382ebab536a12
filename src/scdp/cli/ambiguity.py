"""``scdp ambiguity-report`` and ``plot-ellipse``."""

from __future__ import annotations

from pathlib import Path

from scdp.evaluation.calibration import ambiguity_report, report_markdown
from scdp.evaluation.figures import plot_ellipse as draw_ellipse
from scdp.evaluation.figures import save_figure
from scdp.io import check_output_path, write_json, write_text
from scdp.tasks import get_task


def report(args) -> int:
    out = Path(args.out) if args.out else None
    if out:
        check_output_path(out, force=args.force)
        check_output_path(out.with_suffix(".md"), force=args.force)
    result = ambiguity_report(args.task, n_random=args.scenes, seed=args.seed)
    text = report_markdown(result)
    if out:
        write_json(out, result)
        write_text(out.with_suffix(".md"), text)
    print(text)
    return 0


def plot_ellipse(args) -> int:
    task = get_task(args.task)
    check_output_path(args.out, force=args.force)
    goals = task.validate_goals(args.goals, args.target)
    save_figure(draw_ellipse(task, goals, args.target), args.out)
    print(f"wrote {args.out}")
    return 0
