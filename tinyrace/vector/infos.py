"""The envs' infos merged as ``VectorEnv._add_info`` merges them, each array made once."""

from __future__ import annotations

import functools
from collections.abc import Iterable, Sequence
from operator import itemgetter
from typing import Any

import numpy as np
from gymnasium.vector import VectorEnv

_SCALARS = (int, float, bool)
_DTYPES = {kind: np.dtype(kind) for kind in _SCALARS}  # the arrays _add_info makes for them


@functools.lru_cache(maxsize=64)
def all_true(num_envs: int) -> np.ndarray:
    """``num_envs`` Trues, made once per size and read-only: each mask handed out is a
    copy of it (``np.ones`` costs five such copies)."""
    full = np.ones(num_envs, dtype=np.bool_)
    full.flags.writeable = False
    return full


def merge_infos(infos: Sequence[dict[str, Any] | None], num_envs: int) -> dict[str, Any]:
    """What ``_add_info`` makes of env ``i``'s info for every ``i`` (``None``: no info).

    ``_add_info`` visits env by env and key by key, growing one array per key; here the
    values are gathered per key first and each array is made and filled once. Keys come
    in the same order, arrays get the same dtypes (the first env's value decides) and
    the same ``_key`` masks. Infos that mix dicts and other values under one key take
    ``_add_info`` itself, as do infos that make this merge raise: a value that does not
    fit its key's array raises what ``_add_info`` raises at the first such value it meets.
    """
    try:
        return _merge(infos, num_envs)
    except Exception:
        return _merged_by_gymnasium(infos, num_envs)  # its error, or its merge if none


def _merge(infos: Sequence[dict[str, Any] | None], num_envs: int) -> dict[str, Any]:
    if len(infos) == num_envs:
        alike = _merge_alike(infos, num_envs)
        if alike is not None:
            return alike
    gathered: dict[str, tuple[list[int], list[Any]]] = {}
    for index, info in enumerate(infos):
        if info is None:
            continue
        for key, value in info.items():  # an info that is no dict raises: Gymnasium's error
            entry = gathered.get(key)
            if entry is None:
                gathered[key] = entry = ([], [])
            entry[0].append(index)
            entry[1].append(value)
    merged: dict[str, Any] = {}
    for key, (indices, values) in gathered.items():
        nested = [isinstance(value, dict) for value in values]
        if key != "final_obs" and any(nested) and not all(nested):
            return _merged_by_gymnasium(infos, num_envs)
        if key == "final_obs":
            array: Any = _objects(indices, values, num_envs)
        elif nested[0]:
            per_env: list[dict[str, Any] | None] = [None] * num_envs
            for index, value in zip(indices, values, strict=True):
                per_env[index] = value
            array = _merge(per_env, num_envs)
        else:
            array = _array(indices, values, num_envs)
        if len(indices) == num_envs:
            mask = all_true(num_envs).copy()
        else:
            mask = np.zeros(num_envs, dtype=np.bool_)
            mask[indices] = True
        merged[key], merged[f"_{key}"] = array, mask
    return merged


def check_infos(infos: Sequence[Any], first: int = 0) -> None:
    """Raise what ``_add_info`` raises for an env's info that is no dict (``None``, say),
    which ``merge_infos`` would take for a missing one; ``first``: the first env's index."""
    for index, info in enumerate(infos):
        if not isinstance(info, dict):
            _Merger(first + index + 1)._add_info({}, info, first + index)


def _merge_alike(infos: Sequence[dict[str, Any] | None], num_envs: int) -> dict[str, Any] | None:
    """``merge_infos`` of infos that all have the first one's keys (the common step):
    every mask all True, every array made from a list of all the envs' values, in the
    first info's key order (``_add_info``'s when every env has every key). None when an
    info is missing or has other keys."""
    first = infos[0]
    if not first or type(first) is not dict:
        return None
    keys = tuple(first)
    try:  # every info as long as the first and holding its keys: the same keys
        if list(map(len, infos)).count(len(keys)) != num_envs:  # type: ignore[arg-type]
            return None
        rows = list(map(itemgetter(*keys), infos))  # type: ignore[arg-type]  # None: TypeError
    except (TypeError, KeyError):  # a missing info, or another key
        return None
    # each key with its values (itemgetter gives a row of values, or one value for one key)
    if len(keys) == 1:
        columns: Iterable[tuple[str, Sequence[Any]]] = [(keys[0], tuple(rows))]
    else:
        columns = zip(keys, zip(*rows, strict=True), strict=True)
    full = all_true(num_envs)  # copied per key: each mask its own array
    merged: dict[str, Any] = {}
    for key, values in columns:
        kind = type(values[0])
        if key == "final_obs":
            array: Any = _objects(range(num_envs), values, num_envs)
        elif kind in _SCALARS:
            array = np.array(values)  # the common case: numpy's own type is the first's
            if array.dtype != _DTYPES[kind]:  # other types among them: cast one by one
                array = _array(range(num_envs), values, num_envs)
        elif kind is tuple and list(map(type, values)).count(tuple) == num_envs:
            array = np.fromiter(values, object, num_envs)  # each tuple as the object it is
        else:
            nested = [isinstance(value, dict) for value in values]
            if any(nested) and not all(nested):
                return _merged_by_gymnasium(infos, num_envs)
            if nested[0]:
                array = _merge(values, num_envs)
            else:
                array = _array(range(num_envs), values, num_envs)
        merged[key], merged[f"_{key}"] = array, full.copy()
    return merged


def _array(indices: Iterable[int], values: Sequence[Any], num_envs: int) -> np.ndarray:
    """One key's values in the array ``_add_info`` would make for the first of them."""
    first = values[0]
    kind = type(first)
    if kind in _SCALARS or issubclass(kind, np.number):
        if len(values) == num_envs and list(map(type, values)).count(kind) == num_envs:
            return np.array(values, dtype=kind)  # every env, one type: cast as one by one
        array = np.zeros(num_envs, dtype=kind)
    elif isinstance(first, np.ndarray):
        array = np.zeros((num_envs, *first.shape), dtype=first.dtype)
    else:
        return _objects(indices, values, num_envs)
    for index, value in zip(indices, values, strict=True):  # one by one, as _add_info casts
        array[index] = value
    return array


def _objects(indices: Iterable[int], values: Sequence[Any], num_envs: int) -> np.ndarray:
    array = np.empty(num_envs, dtype=object)  # every item None
    for index, value in zip(indices, values, strict=True):
        array[index] = value
    return array


class _Merger(VectorEnv):
    """Only for ``_add_info``, which reads ``num_envs``."""

    def __init__(self, num_envs: int) -> None:
        self.num_envs = num_envs


def _merged_by_gymnasium(infos: Sequence[dict[str, Any] | None], num_envs: int) -> dict[str, Any]:
    merger, merged = _Merger(num_envs), dict[str, Any]()
    for index, info in enumerate(infos):
        if info is not None:
            merged = merger._add_info(merged, info, index)
    return merged
