"""Flags several commands share, turned into what the library takes."""

from __future__ import annotations

from scdp.data.scenes import check_goal_count


def goal_overrides(args) -> list[str]:
    """The ``--set`` overrides with ``--goals N`` appended as ``data.goals=N`` (checked as ``--goals``)."""
    overrides = list(args.overrides or [])
    if getattr(args, "goals", None) is not None:
        overrides.append(f"data.goals={check_goal_count(args.goals, field='--goals')}")
    return overrides
