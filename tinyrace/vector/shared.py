"""The memory a BatchVectorEnv shares with its workers.

One ``multiprocessing.shared_memory`` block per vector env holds, per env: the
observation (each leaf of a Box / Discrete / MultiBinary / MultiDiscrete space, or a
Dict or Tuple of them), the action (for array action spaces), the reward, the two
episode flags, one fixed-size record of its info and the number of that record's
signature (``tinyrace.vector.records``); per worker: the command, the status of its
answer and, when all its envs' infos share one signature, that signature's number. Each
array is a numpy view made once, so a step moves no bytes through a pipe and pickles
nothing. A worker tells the parent each new signature once, over its pipe;
infos that do not fit go over the pipe as they are.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from multiprocessing import resource_tracker
from multiprocessing.shared_memory import SharedMemory
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.spaces import Box, Dict, Discrete, MultiBinary, MultiDiscrete, Tuple

from tinyrace.vector.records import INFO_BYTES

ALIGN = 64  # [bytes] each array starts on a cache line
LEAVES = (Box, Discrete, MultiBinary, MultiDiscrete)

# what a worker's status word says about its last step
KNOWN = 0  # the records hold the infos, each env's signature numbered in ``kinds``
NEW_SIGNATURES = 1  # as KNOWN, and the pipe carries the signatures the worker numbered anew
INFOS_BY_PIPE = 2  # the infos come over the pipe
FAILED = 3  # the pipe carries the exception

# a worker's command word
STEP = 1  # step with the actions in the shared memory
PIPE = 2  # read the command from the pipe


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

    observations: Any  # the buffer written now: an array, or a dict / tuple of arrays
    buffers: list[Any]  # every observation buffer, as ``observations``
    buffer: np.ndarray  # (1,) int64: the number of the buffer the next step writes
    actions: np.ndarray | None  # None: the action space is not one array
    rewards: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    infos: np.ndarray  # (num_envs, INFO_BYTES) uint8, seen through a signature's dtype
    kinds: np.ndarray  # (num_envs,) int64: the worker's number of each record's signature
    command: np.ndarray  # (workers,) int64
    status: np.ndarray  # (workers,) int64
    uniform: np.ndarray  # (workers,) int64: the worker's number of its envs' one signature, or -1


class Layout:
    """Where each array lies in a block for ``num_envs`` envs and ``workers`` workers, with
    ``buffers`` observation buffers (``tinyrace.vector.handout``)."""

    def __init__(
        self,
        observation_space: gym.Space[Any],
        action_space: gym.Space[Any],
        num_envs: int,
        workers: int,
        buffers: int = 1,
    ) -> None:
        # offsets, shapes and dtypes only: the layout is sent to every worker, and a space
        # holds its bounds (a 96x96x3 Box's pickle takes 110 KB, more than a pipe's buffer)
        self.num_envs, self.workers = num_envs, workers
        self.size = 0
        self.observations = [self._place_space(observation_space) for _ in range(buffers)]
        self._buffer = self._place((), np.int64, 1)
        array_actions = isinstance(action_space, LEAVES) and action_space.shape is not None
        self._actions = (
            self._place(action_space.shape or (), action_space.dtype) if array_actions else None
        )
        self._rewards = self._place((), np.float64)
        self._terminated = self._place((), np.bool_)
        self._truncated = self._place((), np.bool_)
        self._infos = self._place((INFO_BYTES,), np.uint8)
        self._kinds = self._place((), np.int64)
        self._command = self._place((), np.int64, workers)
        self._status = self._place((), np.int64, workers)
        self._uniform = self._place((), np.int64, workers)

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
            return map_places(
                place, lambda o, s, d: np.ndarray(s, dtype=d, buffer=buffer, offset=o)
            )

        buffers = [view(place) for place in self.observations]
        return Views(
            buffers[0],
            buffers,
            view(self._buffer),
            None if self._actions is None else view(self._actions),
            view(self._rewards),
            view(self._terminated),
            view(self._truncated),
            view(self._infos),
            view(self._kinds),
            view(self._command),
            view(self._status),
            view(self._uniform),
        )


def map_places(place: Any, leaf: Any) -> Any:
    """``leaf(offset, shape, dtype)`` for each array of a placed space, nested as it is."""
    if isinstance(place, dict):
        return {key: map_places(p, leaf) for key, p in place.items()}
    if isinstance(place, tuple) and isinstance(place[0], tuple):
        return tuple(map_places(p, leaf) for p in place)
    return leaf(*place)


def create_block(size: int) -> SharedMemory:
    return SharedMemory(create=True, size=max(size, 1))


def attach_block(name: str) -> SharedMemory:
    """A worker's view of the parent's block, not registered with the resource tracker: the
    parent made the block and unlinks it, and only its registration should stand. Python
    3.13 says so with ``track=False``; before, every attach registers, and a registration
    that the tracker holds after the parent's unlink is reported at exit as a leaked block
    that no longer exists (a newcomer saw it twice in 15 ``tinyrace train --subprocesses``
    runs)."""
    if sys.version_info >= (3, 13):
        return SharedMemory(name=name, track=False)
    register = resource_tracker.register
    resource_tracker.register = _not_registered  # this process only, which attaches once
    try:
        return SharedMemory(name=name)
    finally:
        resource_tracker.register = register


def _not_registered(name: object, rtype: str) -> None:
    """resource_tracker.register for an attach (``attach_block``): nothing to register."""


def free_block(block: SharedMemory | None) -> None:
    """Close and unlink ``block`` (once; a block already unlinked is left alone)."""
    if block is None:
        return
    try:
        block.close()
    except BufferError:  # arrays handed out still use the mapping: it goes with the last of
        # them (numpy's own memoryviews hold the mmap), not with this object's finalizer,
        # which would try to close it again and report the same error
        block._mmap = None  # type: ignore[attr-defined]
        block.close()  # the file descriptor
    with contextlib.suppress(FileNotFoundError):
        block.unlink()
