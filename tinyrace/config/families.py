"""Open unions of config sections: list entries whose ``type`` picks their dataclass.

A family is a base class (``TrackFacts`` for ``tracks:``, ``SensorConfig`` for
``sensors:``); its members are the dataclasses added with ``add``, each named by the
default of its ``type`` field. The loader parses an entry of a family by that name, the
YAML reference lists every member, and a new track source or sensor type joins its family
from its own module (or a test) with one call: no edit of the schema.
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

T = TypeVar("T", bound=type)

_FAMILIES: dict[Any, dict[str, type]] = {}
_TYPE_REQUIRED: set[Any] = set()  # families whose entries must name their type


def add(family: Any, member: T) -> T:
    """Make ``member`` (a dataclass with a ``type`` field) a member of ``family``; the first
    member added is what an entry without ``type`` is (unless the family was declared with
    ``type_required``). Returns ``member`` (a decorator)."""
    name = type_of(member)
    known = _FAMILIES.setdefault(family, {})
    if name in known and known[name] is not member:
        raise ValueError(f"{family.__name__}: type {name!r} is taken by {known[name].__name__}")
    known[name] = member
    return member


def declare(family: Any, type_required: bool = False) -> None:
    """Make ``family`` a family, with no member yet (its entries are parsed by ``type``);
    ``type_required``: an entry without ``type`` is refused (no member stands for it)."""
    _FAMILIES.setdefault(family, {})
    if type_required:
        _TYPE_REQUIRED.add(family)


def type_required(family: Any) -> bool:
    """Whether ``family``'s entries must name their ``type``."""
    return family in _TYPE_REQUIRED


def remove(family: Any, name: str) -> None:
    """Take member ``name`` out of ``family`` (a test's toy, when the test ends)."""
    _FAMILIES.get(family, {}).pop(name, None)


def members(family: Any) -> dict[str, type] | None:
    """``family``'s members by type name, in the order added (None: not a family)."""
    try:
        found = _FAMILIES.get(family)
    except TypeError:  # an unhashable hint is no family
        return None
    return dict(found) if found is not None else None


def type_of(member: type) -> str:
    """The ``type`` a member is named by: its ``type`` field's default."""
    for field in dataclasses.fields(member):
        if field.name == "type" and isinstance(field.default, str):
            return field.default
    raise ValueError(f"{member.__name__} has no type field with a default: it names no member")
