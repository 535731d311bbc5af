"""The memory a BatchVectorEnv shares with its workers, and the infos that fit in it.

One ``multiprocessing.shared_memory`` block per vector env holds, per env: the
observation (each leaf of a Box / Discrete / MultiBinary / MultiDiscrete space, or a
Dict or Tuple of them), the action (for array action spaces), the reward, the two
episode flags and one fixed-size record of its info; per worker: the command and the
status of its answer. Each array is a numpy view made once, so a step moves no bytes
through a pipe and pickles nothing.

An info fits in a record when its values are ``float``, ``int`` or ``bool`` (exactly
those types), numpy scalars, tuples of ``float`` or dicts of those (tinyrace's infos
do). Its *signature* (keys and value types, in order) decides the record's layout; a
worker tells the parent a new signature once, over its pipe, and infos that do not
fit go over the pipe as they are. ``merge_columns`` turns a batch of records into the
dict ``merge_infos`` makes of the infos themselves, bit for bit.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from multiprocessing.shared_memory import SharedMemory
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.spaces import Box, Dict, Discrete, MultiBinary, MultiDiscrete, Tuple

INFO_BYTES = 512  # [bytes] per env's info record; a larger info goes over the pipe
MAX_TUPLE = 16  # longest tuple of floats kept in a record
ALIGN = 64  # [bytes] each array starts on a cache line
_PLAIN = (float, int, bool)
_NUMPY = (np.float64, np.float32, np.int64, np.int32, np.bool_)
_SIMPLE = frozenset(_PLAIN + _NUMPY)  # one lookup per value
LEAVES = (Box, Discrete, MultiBinary, MultiDiscrete)

# what a worker's status word says about its last step
NEW_SIGNATURE = 1  # the records hold the infos and the pipe carries their new signature
INFOS_BY_PIPE = 2  # the infos come over the pipe
FAILED = 3  # the pipe carries the exception
# KNOWN + i: the records hold the infos, of the worker's i-th announced signature (infos
# whose shape alternates, such as a reward term present at some steps, cost no message)
KNOWN = 4

# a worker's command word
STEP = 1  # step with the actions in the shared memory
PIPE = 2  # read the command from the pipe

Signature = tuple[Any, ...]  # ((key, kind[, detail]), ...), comparable with ==


def shareable(space: gym.Space[Any]) -> bool:
    """Whether every leaf of ``space`` is an array in shared memory."""
    if isinstance(space, Dict):
        return all(shareable(s) for s in space.values())
    if isinstance(space, Tuple):
        return all(shareable(s) for s in space)
    return isinstance(space, LEAVES)


@dataclass
class Views:
    """Numpy views of one block: the batch's observations, actions and results."""

    observations: Any  # an array, or a dict / tuple of arrays as the space nests
    actions: np.ndarray | None  # None: the action space is not one array
    rewards: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    infos: np.ndarray  # (num_envs, INFO_BYTES) uint8, seen through a signature's dtype
    command: np.ndarray  # (workers,) int64
    status: np.ndarray  # (workers,) int64


class Layout:
    """Where each array lies in a block for ``num_envs`` envs and ``workers`` workers."""

    def __init__(
        self,
        observation_space: gym.Space[Any],
        action_space: gym.Space[Any],
        num_envs: int,
        workers: int,
    ) -> None:
        self.observation_space, self.num_envs, self.workers = observation_space, num_envs, workers
        self.size = 0
        self._observations = self._place_space(observation_space)
        array_actions = isinstance(action_space, LEAVES) and action_space.shape is not None
        self._actions = (
            self._place(action_space.shape or (), action_space.dtype) if array_actions else None
        )
        self._rewards = self._place((), np.float64)
        self._terminated = self._place((), np.bool_)
        self._truncated = self._place((), np.bool_)
        self._infos = self._place((INFO_BYTES,), np.uint8)
        self._command = self._place((), np.int64, workers)
        self._status = self._place((), np.int64, workers)

    def _place(self, shape: Sequence[int], dtype: Any, rows: int | None = None) -> tuple[Any, ...]:
        shape = (self.num_envs if rows is None else rows, *shape)
        dtype = np.dtype(dtype)
        offset = self.size
        self.size = -(-(offset + int(np.prod(shape)) * dtype.itemsize) // ALIGN) * ALIGN
        return offset, shape, dtype

    def _place_space(self, space: gym.Space[Any]) -> Any:
        if isinstance(space, Dict):
            return {key: self._place_space(s) for key, s in space.items()}
        if isinstance(space, Tuple):
            return tuple(self._place_space(s) for s in space)
        return self._place(space.shape, space.dtype)  # type: ignore[arg-type]

    def views(self, buffer: Any) -> Views:
        def view(place: Any) -> Any:
            if isinstance(place, dict):
                return {key: view(p) for key, p in place.items()}
            if isinstance(place, tuple) and isinstance(place[0], tuple):
                return tuple(view(p) for p in place)
            offset, shape, dtype = place
            return np.ndarray(shape, dtype=dtype, buffer=buffer, offset=offset)

        return Views(
            view(self._observations),
            None if self._actions is None else view(self._actions),
            view(self._rewards),
            view(self._terminated),
            view(self._truncated),
            view(self._infos),
            view(self._command),
            view(self._status),
        )


def create_block(size: int) -> SharedMemory:
    return SharedMemory(create=True, size=max(size, 1))


def free_block(block: SharedMemory | None) -> None:
    """Close and unlink ``block`` (once; a block already unlinked is left alone)."""
    if block is None:
        return
    with contextlib.suppress(BufferError):  # views still alive: the OS frees it with them
        block.close()
    with contextlib.suppress(FileNotFoundError):
        block.unlink()


# -- infos ------------------------------------------------------------------------------------
def flatten(info: dict[str, Any]) -> tuple[Signature, list[Any]] | None:
    """``info``'s signature and its values in record order, or None if it does not fit."""
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
            values.append(value)
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


def merge_columns(signature: Signature, rows: np.ndarray) -> dict[str, Any]:
    """What ``merge_infos`` makes of infos with ``signature`` in every env (``rows``)."""
    return merge_bound(bind(signature, rows), len(rows))


# per signature entry: (key, mask key, the records' column (None: a dict), is a tuple,
# the dict's entries)
Bound = tuple[tuple[str, str, np.ndarray | None, bool, Any], ...]


def bind(signature: Signature, rows: np.ndarray) -> Bound:
    """``signature``'s entries bound to their columns of ``rows`` (views, made once: a
    step's merge then copies them)."""
    fields = iter(rows.dtype.names or ())

    def entries(signature: Signature) -> Bound:
        bound: list[tuple[str, str, np.ndarray | None, bool, Any]] = []
        for entry in signature:
            key, kind = entry[0], entry[1]
            if kind is dict:
                bound.append((key, f"_{key}", None, False, entries(entry[2])))
            else:
                bound.append((key, f"_{key}", rows[next(fields)], kind is tuple, None))
        return tuple(bound)

    return entries(signature)


def merge_bound(bound: Bound, n: int) -> dict[str, Any]:
    """The merged infos of the records ``bound`` views (``n`` envs)."""
    every = np.empty(n, dtype=np.bool_)
    every.fill(True)
    return _merge(bound, n, every)


def _merge(bound: Bound, n: int, every: np.ndarray) -> dict[str, Any]:
    merged: dict[str, Any] = {}
    for key, mask, column, is_tuple, inner in bound:
        if column is None:
            array: Any = _merge(inner, n, every)
        elif is_tuple:
            array = np.fromiter(map(tuple, column.tolist()), object, n)
        else:
            array = column.copy()
        merged[key], merged[mask] = array, every.copy()  # each mask its own array
    return merged


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
