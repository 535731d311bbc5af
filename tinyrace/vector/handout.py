"""Observations handed out without a copy: a few buffers that the envs write in turn.

``copy=True`` promises arrays that no later step changes. Copying the batch's frames
costs the parent about a microsecond per 28 KB frame, serially, while the workers wait;
for cheap envs it is most of the vector env's own cost. Instead the envs write each step
into one of ``BUFFERS`` observation buffers, and the parent hands out numpy arrays over
that buffer itself. A buffer is written again only when no array the caller holds (nor
any view of one) refers to it: each hand-out is rooted in an array of its own
(``np.frombuffer``), which every array and view made from it keeps alive as its
``base``, so a weak reference to that root tells. The common loop
(``obs = envs.step(policy(obs))[0]``) holds one or two batches at a time, so three
buffers take turns; a caller that keeps more gets copies.

Writes that leave rows as they were (a reset with ``reset_mask``, the workers of
``AsyncBatch``) start from a copy of the last buffer when they must move to another. A
step that raises leaves the rows it may not have written as they were before it
(``restore``): the envs of the worker that raised show their last observation.
"""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from tinyrace.vector.shared import Layout, Views, map_places

BUFFERS = 3  # observation buffers taking turns when the caller gets arrays over them
MAX_BYTES = 64 * 2**20  # [bytes] above this the buffers' total would strain /dev/shm: 1
# [bytes] a batch of observations smaller than this is copied: a hand-out's fixed cost
# (about 6 µs here) is a copy of some 100 KB (four CarRacing frames), measured
HAND_OUT_FROM = 64 * 2**10


def buffers_for(layout: Layout, copy: bool) -> int:
    """How many observation buffers a vector env of ``layout`` gets: several when it hands
    out copies of a batch large enough to be worth it and they fit in ``MAX_BYTES``, else
    one (and the batch is copied)."""
    one = sum(count * dtype.itemsize for _, count, dtype, _ in _leaves(layout.observations[0]))
    return BUFFERS if copy and HAND_OUT_FROM <= one <= MAX_BYTES // BUFFERS else 1


class Handout:
    """The observation buffers of one vector env's block (shared memory or a bytearray)."""

    def __init__(self, block: Any, layout: Layout, views: Views) -> None:
        self.block, self.views = block, views
        # per buffer, its arrays' (offset, count, dtype, shape) in the space's order
        self.leaves = [_leaves(place) for place in layout.observations]
        # the observations are one array (a Box space, not a Dict or Tuple of them)
        self.single = not isinstance(views.observations, dict | tuple)
        self.copies = len(views.buffers) == 1  # a single buffer: every hand-out a copy
        self.current = 0  # the buffer holding the latest observations
        self.previous: int | None = None  # the one before, if the last write moved
        # per buffer: weak references to the roots of the arrays last handed out over it
        self.handed: list[list[weakref.ref[np.ndarray]] | None] = [None] * len(views.buffers)
        views.buffer[0] = 0

    def write(self, full: bool) -> None:
        """Point the next write at a buffer that no array handed out refers to; ``full``:
        the write covers every row, else the rows it leaves keep the latest values."""
        self.previous = None
        if self.copies or not self._held(self.current):
            return
        free = self._free()
        assert free is not None  # hand_out leaves a buffer free, else it copies
        if not full:
            _copy_rows(self.views.buffers[self.current], self.views.buffers[free], slice(None))
        self.previous, self.current = self.current, free
        self.views.observations = self.views.buffers[free]
        self.views.buffer[0] = free

    def restore(self, rows: slice) -> None:
        """After a write that raised: ``rows`` as they were before it (in place if the
        write did not move to another buffer, where they were never overwritten)."""
        if self.previous is not None:
            _copy_rows(self.views.buffers[self.previous], self.views.buffers[self.current], rows)

    def hand_out(self) -> Any:
        """The latest observations as arrays no later step changes: over their buffer
        when another buffer stays free for the next step, else a copy."""
        k = self.current
        if self.copies or self._free(but=k) is None:
            return _copied(self.views.buffers[k])
        if self.single:  # one array: the common case, without the loop and the nesting
            offset, count, dtype, shape = self.leaves[k][0]
            root = np.frombuffer(self.block, dtype=dtype, count=count, offset=offset)
            self.handed[k] = [weakref.ref(root)]
            return root.reshape(shape)  # its base, as every view's of it, is root
        leases, arrays = [], []
        for offset, count, dtype, shape in self.leaves[k]:
            root = np.frombuffer(self.block, dtype=dtype, count=count, offset=offset)
            leases.append(weakref.ref(root))
            arrays.append(root.reshape(shape))  # its base, as every view's of it, is root
        self.handed[k] = leases
        return _nest(self.views.observations, iter(arrays))

    def _free(self, but: int = -1) -> int | None:
        """The first buffer other than ``but`` that no array handed out refers to."""
        for k in range(len(self.handed)):
            if k != but and not self._held(k):
                return k
        return None

    def _held(self, k: int) -> bool:
        """Whether an array handed out over buffer ``k`` (or a view of one) is alive."""
        leases = self.handed[k]
        if leases is None:
            return False
        for root in leases:  # (a loop: any() with a generator costs twice as much here)
            if root() is not None:
                return True
        self.handed[k] = None
        return False


def _leaves(place: Any) -> list[tuple[int, int, np.dtype, tuple[int, ...]]]:
    found: list[tuple[int, int, np.dtype, tuple[int, ...]]] = []
    map_places(place, lambda o, s, d: found.append((o, int(np.prod(s)), np.dtype(d), s)))
    return found


def _nest(template: Any, arrays: Any) -> Any:
    """The next arrays of ``arrays``, nested as ``template`` (a tree of arrays) is."""
    if isinstance(template, dict):
        return {key: _nest(value, arrays) for key, value in template.items()}
    if isinstance(template, tuple):
        return tuple(_nest(value, arrays) for value in template)
    return next(arrays)


def _copied(tree: Any) -> Any:
    """New arrays with ``tree``'s contents, nested alike."""
    if isinstance(tree, dict):
        return {key: _copied(value) for key, value in tree.items()}
    if isinstance(tree, tuple):
        return tuple(_copied(value) for value in tree)
    return tree.copy()


def _copy_rows(source: Any, target: Any, rows: slice) -> None:
    """``source``'s ``rows`` into ``target``'s, nested alike."""
    if isinstance(source, dict):
        for key, value in source.items():
            _copy_rows(value, target[key], rows)
    elif isinstance(source, tuple):
        for value, part in zip(source, target, strict=True):
            _copy_rows(value, part, rows)
    else:
        target[rows] = source[rows]
