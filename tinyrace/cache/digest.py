"""A content digest of loaded track data: the same files read with the same knobs give the
same digest, in any process; any difference in an array, a number or a name changes it.

Tracks are dataclasses of numpy arrays, numbers, strings and tuples, with a few plain
objects among them (e.g. a nearest-point index); the digest walks them all. Attributes
whose names start with ``_`` are left out: they hold what an object derives from its
public data (caches, plain-float copies), never data of their own.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Mapping
from pathlib import PurePath
from typing import Any

import numpy as np


def digest(value: object) -> str:
    """The hex sha256 of ``value``'s content (see the module docstring for what counts)."""
    hasher = hashlib.sha256()
    _feed(hasher, value)
    return hasher.hexdigest()


def _feed(hasher: Any, value: object) -> None:
    if value is None or isinstance(value, (bool, int, float, str, bytes, PurePath)):
        hasher.update(f"{type(value).__name__}:{value!r};".encode())
    elif isinstance(value, np.ndarray):
        hasher.update(f"array:{value.dtype.str}:{value.shape};".encode())
        hasher.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, np.generic):
        hasher.update(f"scalar:{value.dtype.str}:{value.item()!r};".encode())
    elif isinstance(value, (tuple, list)):
        hasher.update(f"{type(value).__name__}:{len(value)}(".encode())
        for item in value:
            _feed(hasher, item)
        hasher.update(b")")
    elif isinstance(value, Mapping):
        hasher.update(f"mapping:{len(value)}(".encode())
        for key in sorted(value, key=repr):
            _feed(hasher, key)
            _feed(hasher, value[key])
        hasher.update(b")")
    else:
        _feed_object(hasher, value)


def _feed_object(hasher: Any, value: object) -> None:
    cls = type(value)
    if dataclasses.is_dataclass(value):
        names = [f.name for f in dataclasses.fields(value)]
    elif hasattr(value, "__dict__"):
        names = sorted(vars(value))
    else:
        raise TypeError(f"cannot digest a {cls.__qualname__}")
    hasher.update(f"object:{cls.__module__}.{cls.__qualname__}(".encode())
    for name in names:
        if not name.startswith("_"):
            hasher.update(f"{name}=".encode())
            _feed(hasher, getattr(value, name))
    hasher.update(b")")


def freeze(value: object) -> None:
    """Make every numpy array inside ``value`` read-only (the walk of ``digest``), so that no
    holder of shared data can change it for the others."""
    if isinstance(value, np.ndarray):
        value.setflags(write=False)
    elif isinstance(value, (tuple, list)):
        for item in value:
            freeze(item)
    elif isinstance(value, Mapping):
        for item in value.values():
            freeze(item)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            freeze(getattr(value, f.name))
    elif hasattr(value, "__dict__") and not isinstance(value, type):
        for name, item in vars(value).items():
            if not name.startswith("_") or isinstance(item, np.ndarray):
                freeze(item)
