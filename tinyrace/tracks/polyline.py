"""Closed polylines in the plane: arc length, resampling, headings, road edges and tiles.

numpy, except the angles: headings, sines and cosines come from ``math`` (the C
library's, one per point at load time), because numpy picks its SIMD kernels by CPU and
its AVX-512 ones may differ in the last bit, which would start a car differently on
another machine. A loop is an (N, 2) array of points in driving order; the last point
joins the first and is not repeated. World frame: y up, headings counter-clockwise
from +x, so the left of the driving direction is the heading plus 90 degrees.
"""

from __future__ import annotations

import math

import numpy as np


def segment_lengths(loop: np.ndarray) -> np.ndarray:
    """(N,) length of the segment from point i to point i + 1 (the last one closes the loop)."""
    return np.asarray(np.hypot(*(np.roll(loop, -1, axis=0) - loop).T), float)


def cumulative_length(loop: np.ndarray) -> np.ndarray:
    """(N + 1,) arc length at each point, then at the return to point 0 (the perimeter)."""
    return np.concatenate(([0.0], np.cumsum(segment_lengths(loop))))


def perimeter(loop: np.ndarray) -> float:
    """Length of the closed loop, in the points' unit."""
    return float(segment_lengths(loop).sum())


def resample(
    loop: np.ndarray, spacing: float, values: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Points evenly ``spacing`` apart along the loop (the count rounded so that they close
    evenly), starting at point 0; ``values`` (N, K) per point are interpolated alongside."""
    arc = cumulative_length(loop)
    count = max(round(float(arc[-1]) / spacing), 3)
    at = np.linspace(0.0, arc[-1], count, endpoint=False)
    closed = np.vstack((loop, loop[:1]))
    points = np.column_stack([np.interp(at, arc, closed[:, k]) for k in (0, 1)])
    if values is None:
        return points, None
    ring = np.vstack((values, values[:1]))
    return points, np.column_stack([np.interp(at, arc, ring[:, k]) for k in range(ring.shape[1])])


def headings(loop: np.ndarray) -> np.ndarray:
    """(N,) direction of travel at each point [rad], from its two neighbours."""
    ahead = np.roll(loop, -1, axis=0) - np.roll(loop, 1, axis=0)
    return np.array([math.atan2(y, x) for x, y in ahead.tolist()], float)


def curvature(loop: np.ndarray) -> np.ndarray:
    """(N,) signed curvature at each point [1/unit], positive turning left (counter-clockwise)."""
    angle = headings(loop)  # one pass of math.atan2 per point: computed once
    turn = np.diff(np.unwrap(np.concatenate((angle, angle[:1]))))
    step = segment_lengths(loop)
    return np.asarray(np.roll(turn, 1) / np.maximum(0.5 * (step + np.roll(step, 1)), 1e-12))


def left_normals(loop: np.ndarray) -> np.ndarray:
    """(N, 2) unit vectors pointing to the left of the driving direction."""
    return np.array([(-math.sin(a), math.cos(a)) for a in headings(loop).tolist()], float)


def edges(loop: np.ndarray, widths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(left, right) edge points, ``widths`` (N, 2) = (to the right, to the left) of each point."""
    normal = left_normals(loop)
    return loop + normal * widths[:, 1:2], loop - normal * widths[:, 0:1]


def tiles(loop: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """(N, 4, 2) road quads: tile i spans point i to point i + 1, vertices left_i, right_i,
    right_i+1, left_i+1 (a convex quad unless the road folds over itself)."""
    left, right = edges(loop, widths)
    return np.stack((left, right, np.roll(right, -1, axis=0), np.roll(left, -1, axis=0)), axis=1)


def signed_area(loop: np.ndarray) -> float:
    """Shoelace area: positive for a counter-clockwise loop (y up)."""
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def self_intersection(loop: np.ndarray, chunk: int = 256) -> tuple[int, int] | None:
    """The first pair (i, j), i < j, of non-adjacent segments that cross, or None.

    Segment i runs from point i to point i + 1. Quadratic in N but vectorised in chunks
    of ``chunk`` segments against all others, with a bounding-box test first.
    """
    a, b = loop, np.roll(loop, -1, axis=0)
    n = len(loop)
    low, high = np.minimum(a, b), np.maximum(a, b)
    for start in range(0, n, chunk):
        i = np.arange(start, min(start + chunk, n))[:, None]
        j = np.arange(n)[None, :]
        apart = (j > i + 1) & ~((i == 0) & (j == n - 1))  # each pair once, neighbours excluded
        boxes = (
            (low[i, 0] <= high[j, 0])
            & (low[j, 0] <= high[i, 0])
            & (low[i, 1] <= high[j, 1])
            & (low[j, 1] <= high[i, 1])
        )
        ii, jj = np.nonzero(apart & boxes)
        ii = ii + start
        crossing = _crosses(a[ii], b[ii], a[jj], b[jj])
        if crossing.any():
            k = int(np.argmax(crossing))
            return int(ii[k]), int(jj[k])
    return None


def _crosses(p1: np.ndarray, p2: np.ndarray, q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Whether segments p1-p2 and q1-q2 intersect (touching counts), row by row."""
    d1, d2 = _side(q1, q2, p1), _side(q1, q2, p2)
    d3, d4 = _side(p1, p2, q1), _side(p1, p2, q2)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)
    touching = (
        ((d1 == 0) & _within(q1, q2, p1))
        | ((d2 == 0) & _within(q1, q2, p2))
        | ((d3 == 0) & _within(p1, p2, q1))
        | ((d4 == 0) & _within(p1, p2, q2))
    )
    return np.asarray(proper | touching, bool)


def _side(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Sign of the cross product (b - a) x (p - a): which side of line a-b the point p is."""
    cross = (b[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (p[:, 0] - a[:, 0])
    return np.asarray(np.sign(cross), float)


def _within(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Whether p lies in the bounding box of segment a-b (for points on its line)."""
    inside = (
        (np.minimum(a[:, 0], b[:, 0]) <= p[:, 0])
        & (p[:, 0] <= np.maximum(a[:, 0], b[:, 0]))
        & (np.minimum(a[:, 1], b[:, 1]) <= p[:, 1])
        & (p[:, 1] <= np.maximum(a[:, 1], b[:, 1]))
    )
    return np.asarray(inside, bool)


def nearest_index(loop: np.ndarray, point: np.ndarray) -> int:
    """Index of the loop point closest to ``point``."""
    return int(np.argmin(np.hypot(*(loop - point).T)))
