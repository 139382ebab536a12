"""The two tasks of the paper behind one interface (:class:`~scdp.tasks.base.Task`).

The trainer, generator, evaluator and service only ever talk to that interface; a new robot is
a new :class:`Task` subclass and an entry in :data:`TASKS`.
"""

from __future__ import annotations

from scdp.errors import ScdpError
from scdp.messages import preview
from scdp.tasks.base import REACH_MARGIN, Task
from scdp.tasks.block_reach import BLOCK_REACH, BlockReachTask
from scdp.tasks.navigation import NAVIGATION, NavigationTask

__all__ = ["BLOCK_REACH", "NAVIGATION", "REACH_MARGIN", "TASKS", "BlockReachTask", "NavigationTask", "Task", "get_task"]

TASKS = {t.name: t for t in (NAVIGATION, BLOCK_REACH)}


def get_task(name) -> Task:
    """Look a task up by name; raises :class:`ScdpError` on ``task`` for unknown names."""
    if isinstance(name, Task):
        return name
    try:
        return TASKS[name]
    except (KeyError, TypeError):
        raise ScdpError("task", f"unknown task {preview(name, 24)} (choose from {', '.join(TASKS)})") from None
