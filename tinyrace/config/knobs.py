"""``knob()``: a config field that carries its documentation, unit and bounds."""

from __future__ import annotations

import dataclasses
from dataclasses import field
from types import MappingProxyType
from typing import Any


def knob(default: Any, doc: str, unit: str = "", **rules: Any) -> Any:
    """A config field with its documentation, unit and validation rules.

    rules: ``low`` / ``high`` (inclusive bounds; ``low_open=True`` makes ``low`` strict:
    ``low=0.0, low_open=True`` is > 0), ``magnitude`` (the largest absolute value of a
    float, when not ``high``), ``binary`` (colour channels 0 or 255), ``aliases`` (other
    accepted key names). Another rule, or ``low_open`` without ``low``, is a TypeError.
    """
    unknown = set(rules) - _RULES
    if unknown:
        raise TypeError(f"knob rules are {', '.join(sorted(_RULES))}; not {sorted(unknown)}")
    if "low_open" in rules and ("low" not in rules or not isinstance(rules["low_open"], bool)):
        raise TypeError("low_open is True or False and goes with low: low=0.0, low_open=True")
    meta = {"doc": doc, "unit": unit, **rules}
    if isinstance(default, (list, dict, set)):
        raise TypeError("use tuples or MappingProxyType for defaults")
    if default is dataclasses.MISSING:
        return field(metadata=meta)
    if dataclasses.is_dataclass(default):
        return field(default_factory=lambda: default, metadata=meta)
    if isinstance(default, MappingProxyType):  # a free-form mapping: a fresh dict per instance
        return field(default_factory=lambda: dict(default), metadata=meta)
    return field(default=default, metadata=meta)


REQUIRED = dataclasses.MISSING
_RULES = {"low", "high", "low_open", "magnitude", "binary", "aliases"}
