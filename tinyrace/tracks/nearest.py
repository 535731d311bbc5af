"""Exact nearest-point queries on a fixed point set (the trajectory's pixels), built once.

Points are bucketed in a grid and sorted by cell, so that a row of cells is one
contiguous slice. A coarse distance transform of the occupied cells tells, for
any cell, how many rings around it can hold the nearest point; a query reads
only those rows: O(points near the query), never a scan of all points. The
candidates depend on the query's cell (clamped to the grid) and the rings searched alone,
so they are gathered once per such pair (a bounded cache), also for queries beyond the
grid. A query is then a few numpy calls.
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np

CACHED_CELLS = 4096  # (cell, rings) pairs whose candidates are kept (cleared when full)


class NearestPoint:
    """Nearest of a fixed set of 2-D points, in the points' units (pixels)."""

    def __init__(self, points: np.ndarray, cell: float = 32.0):
        if len(points) == 0:
            raise ValueError("NearestPoint needs at least one point")
        points = np.asarray(points, np.float64)
        self.cell = cell
        low = points.min(axis=0)
        self.origin = low
        cols_rows = ((points - low) // cell).astype(np.int64)
        self.cols = int(cols_rows[:, 0].max()) + 1
        self.rows = int(cols_rows[:, 1].max()) + 1
        keys = cols_rows[:, 1] * self.cols + cols_rows[:, 0]
        order = np.argsort(keys, kind="stable")
        self.points = points[order]
        counts = np.bincount(keys, minlength=self.rows * self.cols)
        self.offsets = np.concatenate([[0], np.cumsum(counts)])
        empty = (counts.reshape(self.rows, self.cols) == 0).astype(np.uint8)
        # distance (in cells, centre to centre) from each cell to the nearest occupied cell
        self.reach = cv2.distanceTransform(empty, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        # the same as plain floats: a query does scalar arithmetic, numpy scalars are slow at it
        self._origin = (float(low[0]), float(low[1]))
        self._reach: list[list[float]] = self.reach.tolist()
        self._cells: dict[tuple[int, int, int], tuple[np.ndarray, np.ndarray]] = {}

    def query(self, x: float, y: float) -> tuple[float, float, float]:
        """(distance, nearest x, nearest y) for the point (x, y)."""
        x, y = float(x), float(y)  # as numpy would promote a float32 against float64 points
        fx, fy = (x - self._origin[0]) / self.cell, (y - self._origin[1]) / self.cell
        col = min(max(math.floor(fx), 0), self.cols - 1)
        row = min(max(math.floor(fy), 0), self.rows - 1)
        outside = math.hypot(fx - min(max(fx, 0), self.cols), fy - min(max(fy, 0), self.rows))
        # every point closer than the nearest occupied cell's far corner lies within this many
        # rings of cells (the query's cell clamped to the grid, ``outside`` cells beyond it)
        # (``reach`` is float32: beyond the grid the sum is float32 too, as numpy adds them)
        reach = self._reach[row][col] if outside == 0 else self.reach[row, col] + outside
        rings = math.ceil(reach) + 2
        key = (row, col, rings)
        found = self._cells.get(key)
        if found is None:
            if len(self._cells) >= CACHED_CELLS:
                self._cells.clear()
            found = self._cells[key] = self._candidates(row, col, rings)
        xs, ys = found
        dx, dy = xs - x, ys - y
        d2 = dx * dx + dy * dy
        best = int(d2.argmin())  # the method: no numpy dispatch wrapper
        return math.sqrt(d2[best]), float(xs[best]), float(ys[best])

    def _candidates(self, row: int, col: int, rings: int) -> tuple[np.ndarray, np.ndarray]:
        """(x, y) of every point in the cells within ``rings`` of cell (row, col), in a fixed
        order."""
        r0, r1 = max(row - rings, 0), min(row + rings, self.rows - 1)
        c0, c1 = max(col - rings, 0), min(col + rings, self.cols - 1)
        starts = self.offsets[np.arange(r0, r1 + 1) * self.cols + c0]
        ends = self.offsets[np.arange(r0, r1 + 1) * self.cols + c1 + 1]
        candidates = np.concatenate([self.points[a:b] for a, b in zip(starts, ends, strict=True)])
        return np.ascontiguousarray(candidates[:, 0]), np.ascontiguousarray(candidates[:, 1])

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_cells": {}}  # a cache: refilled when queried
