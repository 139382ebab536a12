"""A task's content key: what its definition is, so that every output made from it is redone when
it changes (``scdp reproduce``, :mod:`scdp.training.made_from`).

A task is its fields (dimensions, sampling boxes, demonstration bends such as ``lateral_cap``, the
calibrated ambiguity settings that SCDP's arbitration reads, the layouts, ...) and its code: the
source of its class and of every class between it and :class:`~scdp.tasks.base.Task`. Both go into
:func:`task_fingerprint`; a changed field or a changed method of a task of your own changes it.
What the library's :class:`Task` base itself does is covered by the format of what stages write
(:data:`scdp.training.made_from.FORMAT`), not by this key.
"""

from __future__ import annotations

import dataclasses
import hashlib
import inspect
import json

import numpy as np

from scdp.tasks.base import Task


def _jsonable(value):
    """A field's value as plain JSON (arrays and tuples as lists, dataclasses as dicts)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return repr(value)


def _class_source(cls: type) -> str:
    """The source of ``cls`` (its qualified name where Python holds no source, e.g. a class made at run time)."""
    try:
        return inspect.getsource(cls)
    except (OSError, TypeError):
        return f"{cls.__module__}.{cls.__qualname__}"


def task_definition(task: Task) -> dict:
    """What :func:`task_fingerprint` hashes: ``fields`` (name -> JSON value) and ``classes``
    (qualified name -> source, from the task's own class up to, not including, :class:`Task`)."""
    fields = {f.name: _jsonable(getattr(task, f.name)) for f in dataclasses.fields(task)}
    classes = {f"{c.__module__}.{c.__qualname__}": _class_source(c)
               for c in type(task).__mro__ if isinstance(c, type) and issubclass(c, Task) and c is not Task}
    return {"fields": fields, "classes": classes}


def task_fingerprint(task: Task) -> str:
    """SHA-256 of :func:`task_definition` as canonical JSON."""
    text = json.dumps(task_definition(task), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()
