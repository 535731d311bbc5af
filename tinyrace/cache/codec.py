"""A dataclass as a cache entry: its arrays by field name, its other fields as JSON.

Fields may hold arrays, None, numbers (numpy scalars keep their type), strings, booleans,
and tuples or lists of these; the dataclass is made again from its fields (``cls(**...)``),
so whatever ``__post_init__`` derives is derived again.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, Generic, TypeVar

import numpy as np

from tinyrace.cache.disk import Arrays, Entry

T = TypeVar("T")


class DataclassCodec(Generic[T]):
    """Encodes instances of the dataclass ``cls``; ``prepare`` completes an instance first
    (e.g. makes the levels it would make lazily)."""

    def __init__(self, cls: type[T], prepare: Callable[[T], None] | None = None):
        self.cls = cls
        self.prepare = prepare

    def encode(self, value: T) -> Entry:
        if self.prepare is not None:
            self.prepare(value)
        arrays: Arrays = {}
        values = {
            f.name: _encode(getattr(value, f.name), f.name, arrays)
            for f in dataclasses.fields(self.cls)  # type: ignore[arg-type]
            if f.init
        }
        return Entry(values, arrays)

    def decode(self, entry: Entry) -> T:
        fields = {name: _decode(item, entry.arrays) for name, item in entry.values.items()}
        return self.cls(**fields)


def _encode(value: Any, path: str, arrays: Arrays) -> Any:
    if isinstance(value, np.ndarray):
        arrays[path] = value
        return {"array": path}
    if isinstance(value, np.generic):
        return {"scalar": [value.dtype.str, value.item()]}
    if isinstance(value, (tuple, list)):
        items = [_encode(item, f"{path}.{i}", arrays) for i, item in enumerate(value)]
        return {type(value).__name__: items}
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise TypeError(f"cannot store a {type(value).__qualname__} in a cache file ({path})")


def _decode(item: Any, arrays: Arrays) -> Any:
    if not isinstance(item, dict):
        return item
    if "array" in item:
        return arrays[item["array"]]
    if "scalar" in item:
        dtype, number = item["scalar"]
        return np.dtype(dtype).type(number)
    if "tuple" in item:
        return tuple(_decode(x, arrays) for x in item["tuple"])
    return [_decode(x, arrays) for x in item["list"]]
