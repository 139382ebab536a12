"""Validated frozen dataclasses: the base of every configuration section (:mod:`scdp.config`).

A :class:`Section` checks the type of every field against its annotation on construction
(int, float, bool, str, tuples, optional values, nested sections), then ``_positive`` fields
and its own ``_check``; it round-trips through JSON. :func:`assign` sets one nested field from
a ``section.field=value`` override and re-validates every level.
"""

from __future__ import annotations

import math
import types
import typing
from dataclasses import asdict, fields, is_dataclass, replace

from scdp.errors import ScdpError


def _type_ok(value, hint) -> bool:
    """Does ``value`` fit the annotation ``hint`` (int, float, bool, str, tuples, unions, configs)?"""
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        return any(_type_ok(value, h) for h in typing.get_args(hint))
    if hint is type(None):
        return value is None
    if origin is tuple:
        item = typing.get_args(hint)[0]
        return isinstance(value, tuple) and len(value) > 0 and all(_type_ok(v, item) for v in value)
    if hint is bool:
        return isinstance(value, bool)
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if hint is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    return isinstance(value, hint)


def _type_name(hint) -> str:
    return str(hint).replace("typing.", "").replace("<class '", "").replace("'>", "")


class Section:
    """Base of every section: type checks on construction, JSON round trip, range checks.

    Subclasses list ``_positive`` fields (> 0 when set) and may add ``_check``.
    """

    _positive: typing.ClassVar[tuple[str, ...]] = ()

    def __post_init__(self):
        hints = typing.get_type_hints(type(self))
        for f in fields(self):
            hint, value = hints[f.name], getattr(self, f.name)
            if isinstance(value, list):  # JSON gives lists where tuples belong
                value = tuple(value)
                object.__setattr__(self, f.name, value)
            if not _type_ok(value, hint):
                raise ScdpError(self._field(f.name), f"expected {_type_name(hint)}, got {value!r}")
            if hint is float and isinstance(value, int):
                object.__setattr__(self, f.name, float(value))
        for name in self._positive:
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise ScdpError(self._field(name), f"must be > 0, got {value}")
        self._check()

    def _check(self) -> None:
        """Range checks beyond types and positivity."""

    def _field(self, name: str) -> str:
        return name

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data):
        """Build from a JSON object; nested sections are built by their own ``from_dict``."""
        if not isinstance(data, dict):
            raise ScdpError(cls.__name__, f"expected a JSON object, got {type(data).__name__}")
        hints = typing.get_type_hints(cls)
        names = {f.name for f in fields(cls)}
        unknown = set(data) - names
        if unknown:
            raise ScdpError(cls.__name__, f"unknown fields {sorted(unknown)}")
        kwargs = {}
        for key, value in data.items():
            section = section_class(hints[key])
            kwargs[key] = section.from_dict(value) if section is not None and isinstance(value, dict) else value
        try:
            return cls(**kwargs)
        except TypeError as exc:  # a required field is missing
            raise ScdpError(cls.__name__, str(exc).split(".__init__() ")[-1]) from None


def section_class(hint):
    """The config class inside an annotation like ``TrainConfig | None``, or None."""
    for h in (hint, *typing.get_args(hint)):
        if isinstance(h, type) and is_dataclass(h) and issubclass(h, Section):
            return h
    return None


def assign(obj, keys: list[str], value, path: str):
    """``replace`` a nested field, re-validating every level on the way back up."""
    names = {f.name for f in fields(obj)}
    if keys[0] not in names or keys[0] in ("name", "overrides"):
        raise ScdpError("--set", f"{path}: no field {keys[0]!r} in {type(obj).__name__} (fields: {', '.join(sorted(names))})")
    current = getattr(obj, keys[0])
    if len(keys) > 1:
        if current is None:  # an unset optional schedule: start from the main one
            raise ScdpError("--set", f"{path}: {keys[0]} is unset; set the whole value as JSON instead")
        if not is_dataclass(current):
            raise ScdpError("--set", f"{path}: {keys[0]} has no fields")
        value = assign(current, keys[1:], value, path)
    elif is_dataclass(current) and isinstance(value, dict):
        value = type(current).from_dict(value)
    elif current is None and isinstance(value, dict):
        value = section_class(typing.get_type_hints(type(obj))[keys[0]]).from_dict(value)
    try:
        return replace(obj, **{keys[0]: value})
    except ScdpError as exc:
        raise ScdpError("--set", f"{path}: {exc.message}") from None
