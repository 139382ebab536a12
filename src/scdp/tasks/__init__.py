"""The tasks behind one interface (:class:`~scdp.tasks.base.Task`), and how a command finds one.

The trainer, generator, evaluator and service only ever talk to that interface. The paper's two
tasks are built in (``navigation``, ``block_reach``); a robot of your own is a :class:`Task`
defined in your own code and found by :func:`get_task` in one of two ways (docs/tasks.md):

* ``--task package.module:OBJECT``: ``OBJECT`` is a :class:`Task` (or a function of no arguments
  returning one) in an importable module; the working directory is searched first, as
  ``python -m`` and uvicorn do;
* an entry point in the group :data:`ENTRY_POINT_GROUP` of an installed package, named by the
  task's name (``[project.entry-points."scdp.tasks"] my_arm = "my_pkg.task:TASK"``), then
  ``--task my_arm``.

Every task found outside the library passes :func:`scdp.tasks.contract.check_contract` before
any command uses it; a task that breaks the contract is refused in one line naming the member.
"""

from __future__ import annotations

import importlib
import os
import sys
from importlib.metadata import entry_points

from scdp.errors import ScdpError
from scdp.messages import preview
from scdp.tasks.base import REACH_MARGIN, Task
from scdp.tasks.block_reach import BLOCK_REACH, BlockReachTask
from scdp.tasks.contract import check_contract
from scdp.tasks.navigation import NAVIGATION, NavigationTask

__all__ = ["BLOCK_REACH", "ENTRY_POINT_GROUP", "NAVIGATION", "REACH_MARGIN", "TASKS", "BlockReachTask",
           "NavigationTask", "Task", "find_task", "get_task", "task_reference"]

TASKS = {t.name: t for t in (NAVIGATION, BLOCK_REACH)}  # the built-in tasks, by name
ENTRY_POINT_GROUP = "scdp.tasks"
_LOADED: dict[str, tuple[str, Task]] = {}  # tasks found outside the library in this process: name -> (reference, task)


def get_task(name) -> Task:
    """The task ``name`` refers to: a :class:`Task` itself, a built-in name, the name of a task
    already loaded in this process, ``module:OBJECT``, or an installed entry point's name.
    Raises :class:`ScdpError` on ``task`` when none fits, or when the task breaks its contract."""
    if isinstance(name, Task):
        return name
    if not isinstance(name, str) or not name:
        raise ScdpError("task", f"must be a task name or module:OBJECT, got {preview(name, 24)}")
    if name in TASKS:
        return TASKS[name]
    if name in _LOADED:
        return _LOADED[name][1]
    for reference, task in _LOADED.values():
        if reference == name:
            return task
    if ":" in name:
        return _register(name, _import_object(name))
    found = entry_points(group=ENTRY_POINT_GROUP, name=name)
    if found:
        point = next(iter(found))
        try:
            obj = point.load()
        except Exception as exc:  # a broken plugin names itself, whatever it raised
            raise ScdpError("task", f"entry point {name!r} ({point.value}) failed to load: "
                                    f"{type(exc).__name__}: {preview(str(exc), 80)}") from None
        return _register(name, _instance(obj, point.value))
    installed = sorted(p.name for p in entry_points(group=ENTRY_POINT_GROUP))
    raise ScdpError("task", f"unknown task {preview(name, 40)} (built in: {', '.join(TASKS)}"
                            f"{'; installed: ' + ', '.join(installed) if installed else ''}; "
                            "or module:OBJECT for a task in your own code, docs/tasks.md)")


def find_task(name: str) -> Task | None:
    """The task called ``name`` if it is built in or already loaded in this process, else None
    (never imports anything: for readers of a stored task name)."""
    if name in TASKS:
        return TASKS[name]
    return _LOADED[name][1] if name in _LOADED else None


def task_reference(task: Task | str) -> str:
    """What :func:`get_task` takes to find ``task`` (a Task or its name) again in another process:
    its name, or the ``module:OBJECT`` it was loaded from in this one."""
    name = task if isinstance(task, str) else task.name
    return _LOADED[name][0] if name in _LOADED else name


def _import_object(reference: str):
    module_name, _, attribute = reference.partition(":")
    if not module_name or not attribute:
        raise ScdpError("task", f"{preview(reference, 40)}: expected package.module:OBJECT")
    if os.getcwd() not in sys.path and "" not in sys.path:
        sys.path.insert(0, os.getcwd())  # a task in the user's own folder, as `python -m` would find it
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ScdpError("task", f"cannot import {module_name!r} for {reference!r}: {exc}") from None
    except Exception as exc:
        raise ScdpError("task", f"importing {module_name!r} failed: {type(exc).__name__}: {preview(str(exc), 80)}") from None
    obj = module
    for part in attribute.split("."):
        if not hasattr(obj, part):
            raise ScdpError("task", f"{module_name!r} has no {attribute!r}")
        obj = getattr(obj, part)
    return _instance(obj, reference)


def _instance(obj, reference: str) -> Task:
    """``obj`` itself when a Task, else what calling it returns (a factory), checked to be one."""
    if not isinstance(obj, Task) and callable(obj) and not isinstance(obj, type):
        try:
            obj = obj()
        except Exception as exc:
            raise ScdpError("task", f"{reference} failed to build its task: {type(exc).__name__}: "
                                    f"{preview(str(exc), 80)}") from None
    if not isinstance(obj, Task):
        raise ScdpError("task", f"{reference} is a {type(obj).__name__}, not a scdp.tasks.Task (docs/tasks.md)")
    return obj


def _register(reference: str, task: Task) -> Task:
    check_contract(task, reference)
    if task.name in TASKS:
        raise ScdpError("task", f"{reference} is named {task.name!r}, a built-in task's name; choose another")
    known = _LOADED.get(task.name)
    if known is not None and known[1] is not task:
        raise ScdpError("task", f"{reference} is named {task.name!r}, as {known[0]} is; task names must differ")
    _LOADED[task.name] = (reference, task)
    return task
