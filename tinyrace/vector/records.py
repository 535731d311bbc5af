"""Infos as fixed-size records in shared memory, and their merge as ``_add_info`` merges them.

An info fits in a record when its values are ``float``, ``int`` or ``bool`` (exactly
those types), numpy numbers, tuples of ``float`` or dicts of those (tinyrace's infos
do). Its *signature* (keys and value types, in order) decides the record's layout. Each
env's record is written with its own signature, so the envs of one worker may differ
(CarRacing's reward terms gain a key on the steps that reach a tile).

A worker packs each record with ``struct`` (``record_struct``: the same bytes as numpy's
``record_dtype`` writes, in half the time); a float32 signalling NaN arrives quieted
(struct converts it through a double).

A ``Plan`` merges the records of envs whose signatures are known into the dict that
``merge_infos`` makes of the infos themselves, bit for bit: keys in the order of their
first appearance env by env, arrays of the first value's type, zeros (or ``None``)
where an env lacks a key, and the ``_key`` masks. Signatures that give one key two
types take the infos one by one (``unflatten`` and ``merge_infos``).
"""

from __future__ import annotations

import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from tinyrace.vector.infos import all_true

INFO_BYTES = 512  # [bytes] per env's info record; a larger info goes over the pipe
MAX_TUPLE = 16  # longest tuple of floats kept in a record
_PLAIN = (float, int, bool)
# numpy numbers: _add_info makes arrays of their dtype (np.bool_ is no number: objects)
_NUMPY = (np.float64, np.float32, np.int64, np.int32)
_SIMPLE = frozenset(_PLAIN + _NUMPY)  # one lookup per value
# struct's code of each kind (native byte order, standard sizes: numpy's native fields)
_CODES = {float: "d", int: "q", bool: "?", np.float64: "d", np.float32: "f"}
_CODES.update({np.int64: "q", np.int32: "i"})

Signature = tuple[Any, ...]  # ((key, kind[, detail]), ...), comparable with ==


def flatten(info: dict[str, Any]) -> tuple[Signature, list[Any]] | None:
    """``info``'s signature and its values in record order (a tuple's items one by one,
    as ``record_struct`` packs them), or None if it does not fit."""
    if not info and isinstance(info, dict):  # (an info of None raises, as in _add_info)
        return (), []
    signature: list[Any] = []
    values: list[Any] = []
    for key, value in info.items():
        kind = type(value)
        if kind in _SIMPLE:
            signature.append((key, kind))
            values.append(value)
        elif kind is tuple:
            if not 0 < len(value) <= MAX_TUPLE:
                return None
            for item in value:
                if type(item) is not float:
                    return None
            signature.append((key, tuple, len(value)))
            values.extend(value)
        elif kind is dict:
            inner = flatten(value)
            if inner is None:
                return None
            signature.append((key, dict, inner[0]))
            values.extend(inner[1])
        else:
            return None
    return tuple(signature), values


def record_dtype(signature: Signature) -> np.dtype | None:
    """The record layout of infos with ``signature``; None if it exceeds INFO_BYTES."""
    fields: list[tuple[Any, ...]] = []
    for kind, length in _leaves(signature):
        name = f"f{len(fields)}"
        if kind is tuple:
            fields.append((name, np.float64, (length,)))
        else:
            fields.append((name, np.dtype(kind)))
    dtype = np.dtype(fields)
    return dtype if dtype.itemsize <= INFO_BYTES else None


def record_struct(signature: Signature) -> struct.Struct | None:
    """``record_dtype``'s layout as a ``struct`` packs it (numpy's structured dtypes leave no
    padding, nor does ``=``); None if it exceeds INFO_BYTES."""
    codes = [f"{length}d" if kind is tuple else _CODES[kind] for kind, length in _leaves(signature)]
    layout = struct.Struct("=" + "".join(codes))
    return layout if layout.size <= INFO_BYTES else None


def _leaves(signature: Signature) -> Iterator[tuple[Any, int]]:
    for entry in signature:
        if entry[1] is dict:
            yield from _leaves(entry[2])
        else:
            yield entry[1], entry[2] if entry[1] is tuple else 0


def records(infos: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """The rows of ``infos`` (uint8, INFO_BYTES per env) as records of ``dtype``."""
    rows: np.ndarray = np.ndarray(
        (len(infos),), dtype=dtype, buffer=infos, offset=0, strides=(INFO_BYTES,)
    )
    return rows


def unflatten(signature: Signature, row: np.void) -> dict[str, Any]:
    """One record back as the info it was written from (the same types and values)."""
    values = iter(row[name] for name in row.dtype.names or ())
    return _rebuild(signature, values)


def _rebuild(signature: Signature, values: Iterator[Any]) -> dict[str, Any]:
    info: dict[str, Any] = {}
    for entry in signature:
        key, kind = entry[0], entry[1]
        if kind is dict:
            info[key] = _rebuild(entry[2], values)
        elif kind is tuple:
            info[key] = tuple(next(values).tolist())
        elif kind in _PLAIN:
            info[key] = kind(next(values).item())
        else:
            info[key] = kind(next(values))
    return info


# -- merging ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Leaf:
    """A key with values: the signatures (by number) that have it, and its columns, one per
    place in the records (signatures that lay it out alike share one)."""

    key: str
    having: frozenset[int]
    columns: tuple[tuple[frozenset[int], np.ndarray], ...]
    dtype: np.dtype | None  # None: tuples, merged as objects


@dataclass(frozen=True)
class Branch:
    """A key whose values are dicts, merged key by key."""

    key: str
    having: frozenset[int]
    entries: tuple[Leaf | Branch, ...]


class Plan:
    """How the records of envs with the signatures ``order`` (numbered, in the order of their
    first appearance env by env) merge, bound to the columns of ``infos`` (views made once:
    a merge copies them). ``Plan.of`` returns None when a key has two types."""

    def __init__(self, order: tuple[int, ...], entries: tuple[Leaf | Branch, ...]) -> None:
        self.order = order
        self.every = frozenset(order)
        self._steps = self._compile(entries)

    @classmethod
    def of(cls, signatures: Sequence[tuple[int, Signature]], infos: np.ndarray) -> Plan | None:
        """The plan for ``signatures`` ((number, signature) in order of first appearance)
        over ``infos`` (uint8 rows, INFO_BYTES each)."""
        columns: dict[int, dict[tuple[str, ...], np.ndarray]] = {}
        for number, signature in signatures:
            dtype = record_dtype(signature)
            assert dtype is not None  # the worker checked it
            columns[number] = _columns(signature, records(infos, dtype))
        entries = _level(list(signatures), columns, ())
        return None if entries is None else cls(tuple(n for n, _ in signatures), entries)

    def merge(self, numbers: np.ndarray) -> dict[str, Any]:
        """The merged infos of envs whose signatures are ``numbers`` (one per env)."""
        n = len(numbers)
        full = all_true(n)  # copied per key: each mask its own array
        if len(self.order) == 1:
            masks = {self.order[0]: full}
        else:
            masks = {number: numbers == number for number in self.order}
        return self._merge(self._steps, n, masks, full)

    def merge_alike(self, n: int) -> dict[str, Any]:
        """The merged infos of ``n`` envs, all of this plan's one signature."""
        if not self._steps:
            return {}
        full = all_true(n)
        return self._merge(self._steps, n, {self.order[0]: full}, full)

    def _compile(self, entries: tuple[Leaf | Branch, ...]) -> tuple[_Step, ...]:
        """Each entry as (key, mask key, in every env, how, what): decided once, not per
        merge."""
        steps: list[_Step] = []
        for entry in entries:
            everywhere = entry.having == self.every
            what: Any
            if isinstance(entry, Branch):
                how, what = _BRANCH, self._compile(entry.entries)
            elif everywhere and len(entry.columns) == 1:
                how, what = (_TUPLES if entry.dtype is None else _COPY), entry.columns[0][1]
            else:
                how, what = (_SOME_TUPLES if entry.dtype is None else _SPREAD), entry
            steps.append((entry.key, f"_{entry.key}", everywhere, entry.having, how, what))
        return tuple(steps)

    def _merge(
        self, steps: tuple[_Step, ...], n: int, masks: dict[int, np.ndarray], full: np.ndarray
    ) -> dict[str, Any]:
        merged: dict[str, Any] = {}
        for key, mask_key, everywhere, having, how, what in steps:
            if how is _COPY:
                value: Any = what.copy()
            elif how is _TUPLES:
                value = np.fromiter(map(tuple, what.tolist()), object, n)
            elif how is _BRANCH:
                value = self._merge(what, n, masks, full)
            elif how is _SOME_TUPLES:
                value = _objects(what, n, masks)
            else:
                value = np.zeros(n, dtype=what.dtype)
                for group, column in what.columns:
                    np.copyto(value, column, where=_where(masks, group))
            merged[key] = value
            merged[mask_key] = full.copy() if everywhere else _any(masks, having)
        return merged


# how a plan's step makes its value
_COPY, _TUPLES, _BRANCH, _SOME_TUPLES, _SPREAD = "copy", "tuples", "branch", "some", "spread"
_Step = tuple[str, str, bool, frozenset[int], str, Any]


def merge_columns(signature: Signature, rows: np.ndarray) -> dict[str, Any]:
    """What ``merge_infos`` makes of infos with ``signature`` in every env (``rows``: their
    records)."""
    infos = np.zeros((len(rows), INFO_BYTES), np.uint8)
    records(infos, rows.dtype)[:] = rows
    plan = Plan.of([(0, signature)], infos)
    assert plan is not None  # one signature: one type per key
    return plan.merge(np.zeros(len(rows), np.int64))


def _columns(signature: Signature, rows: np.ndarray) -> dict[tuple[str, ...], np.ndarray]:
    """Each leaf's column of ``rows``, by its key path."""
    fields = iter(rows.dtype.names or ())
    found: dict[tuple[str, ...], np.ndarray] = {}

    def walk(signature: Signature, path: tuple[str, ...]) -> None:
        for entry in signature:
            if entry[1] is dict:
                walk(entry[2], (*path, entry[0]))
            else:
                leaf = (*path, entry[0])
                found[leaf] = rows[next(fields)]

    walk(signature, ())
    return found


def _level(
    signatures: list[tuple[int, Signature]],
    columns: dict[int, dict[tuple[str, ...], np.ndarray]],
    path: tuple[str, ...],
) -> tuple[Leaf | Branch, ...] | None:
    """One level's entries, keys in order of first appearance; None if a key has two types."""
    having: dict[str, list[tuple[int, Any]]] = {}
    for number, signature in signatures:
        for entry in signature:
            having.setdefault(entry[0], []).append((number, entry))
    entries: list[Leaf | Branch] = []
    for key, found in having.items():
        kinds = {entry[1] for _, entry in found}
        if len(kinds) != 1:
            return None
        numbers = frozenset(number for number, _ in found)
        kind = kinds.pop()
        if kind is dict:
            inner = _level([(n, entry[2]) for n, entry in found], columns, (*path, key))
            if inner is None:
                return None
            entries.append(Branch(key, numbers, inner))
            continue
        places: dict[tuple[Any, ...], tuple[set[int], np.ndarray]] = {}
        leaf = (*path, key)
        for number, _ in found:
            column = columns[number][leaf]
            place = (column.__array_interface__["data"][0], column.dtype.str, column.shape)
            places.setdefault(place, (set(), column))[0].add(number)
        grouped = tuple((frozenset(group), column) for group, column in places.values())
        entries.append(Leaf(key, numbers, grouped, None if kind is tuple else np.dtype(kind)))
    return tuple(entries)


def _any(masks: dict[int, np.ndarray], numbers: frozenset[int]) -> np.ndarray:
    """Which envs have one of the signatures ``numbers`` (a new array)."""
    chosen = [masks[number] for number in numbers]
    mask: np.ndarray = chosen[0].copy()
    for other in chosen[1:]:
        mask |= other
    return mask


def _where(masks: dict[int, np.ndarray], numbers: frozenset[int]) -> np.ndarray:
    """Which envs have one of the signatures ``numbers``, to read (the mask itself for one
    signature: no copy)."""
    if len(numbers) == 1:
        (number,) = numbers
        return masks[number]
    return _any(masks, numbers)


def _objects(leaf: Leaf, n: int, masks: dict[int, np.ndarray]) -> np.ndarray:
    """A tuple key's values as ``_add_info`` keeps them: an object array, None where absent."""
    values = np.empty(n, dtype=object)  # every item None
    for having, column in leaf.columns:
        rows = np.flatnonzero(_where(masks, having))
        for row, value in zip(rows.tolist(), column[rows].tolist(), strict=True):
            values[row] = tuple(value)
    return values
