"""``knob()``: a config field that carries its documentation, unit and bounds."""

from __future__ import annotations

import dataclasses
from dataclasses import field
from types import MappingProxyType
from typing import Any


def knob(default: Any, doc: str, unit: str = "", **rules: Any) -> Any:
    """A config field with its documentation, unit and validation rules.

    rules: low / high (inclusive bounds), low_open (strict lower bound),
    binary (colour channels 0 or 255), aliases (other accepted key names).
    """
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
