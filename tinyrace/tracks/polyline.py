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

from tinyrace.config.bounds import MAX_CROSSING_PAIRS


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


def start_heading(loop: np.ndarray, heading: np.ndarray) -> float:
    """The direction of travel at point 0 [rad], given ``heading`` (N,) from its neighbours.

    Where a straight meets a curve at point 0 (points 0, 1, 2 lie on a line and -2, -1, 0
    do not, or the other way round) the tangent there is the straight's direction: the
    direction from the neighbour before to the one after leans toward the curve by half the
    turn over one spacing (0.17 rad at 2 m on a 3 m radius). Elsewhere, on a curve or in a
    straight, it is ``heading[0]``, the tangent of the circle through the three points."""
    ahead = _in_line(loop[0], loop[1], loop[2])
    behind = _in_line(loop[-2], loop[-1], loop[0])
    if ahead == behind:
        return float(heading[0])
    dx, dy = (loop[1] - loop[0]) if ahead else (loop[0] - loop[-1])
    return math.atan2(float(dy), float(dx))


def _in_line(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> bool:
    """Whether b -> c goes on in the direction of a -> b (within 1e-9 rad)."""
    (ux, uy), (vx, vy) = (b - a).tolist(), (c - b).tolist()
    cross, dot = ux * vy - uy * vx, ux * vx + uy * vy
    return bool(dot > 0 and abs(cross) <= 1e-9 * math.hypot(ux, uy) * math.hypot(vx, vy))


def curvature(loop: np.ndarray) -> np.ndarray:
    """(N,) signed curvature at each point [1/unit], positive turning left (counter-clockwise)."""
    angle = headings(loop)  # one pass of math.atan2 per point: computed once
    turn = np.diff(np.unwrap(np.concatenate((angle, angle[:1]))))
    step = segment_lengths(loop)
    return np.asarray(np.roll(turn, 1) / np.maximum(0.5 * (step + np.roll(step, 1)), 1e-12))


def left_normals(loop: np.ndarray, heading: np.ndarray | None = None) -> np.ndarray:
    """(N, 2) unit vectors pointing to the left of the driving direction (``heading`` (N,)
    [rad] when given, else ``headings(loop)``)."""
    angles = headings(loop) if heading is None else heading
    return np.array([(-math.sin(a), math.cos(a)) for a in angles.tolist()], float)


def edges(
    loop: np.ndarray, widths: np.ndarray, heading: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(left, right) edge points, ``widths`` (N, 2) = (to the right, to the left) of each point."""
    normal = left_normals(loop, heading)
    return loop + normal * widths[:, 1:2], loop - normal * widths[:, 0:1]


def tiles(loop: np.ndarray, widths: np.ndarray, heading: np.ndarray | None = None) -> np.ndarray:
    """(N, 4, 2) road quads: tile i spans point i to point i + 1, vertices left_i, right_i,
    right_i+1, left_i+1 (a convex quad unless the road folds over itself)."""
    left, right = edges(loop, widths, heading)
    return np.stack((left, right, np.roll(right, -1, axis=0), np.roll(left, -1, axis=0)), axis=1)


def inner_width_over_radius(loop: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """(N,) the road's width to the inside of the curve at each point over the curve's
    radius there, the radius measured over the arc of that width to each side (0 on a
    straight). Above 1 the inner edge passes the curve's centre and the road folds over
    itself; measured at the width's own scale, the small kinks of surveyed data at a
    hairpin's apex count for little. ``widths`` (N, 2) = (to the right, to the left)."""
    curve = _curve_over_width(loop, widths)
    inner = np.where(curve > 0, widths[:, 1], widths[:, 0])
    return np.asarray(inner * np.abs(curve))


def curve_turns_left(loop: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """(N,) bool: the curve at each point, measured as ``inner_width_over_radius`` measures
    it, turns left (its inside is the road's left)."""
    return np.asarray(_curve_over_width(loop, widths) > 0)


def _curve_over_width(loop: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """(N,) [1/unit] the turn over the arc of the wider width to each side of each point,
    per unit of that arc (positive turning left)."""
    n = len(loop)
    angle = np.unwrap(headings(loop))
    close = angle[0] - angle[-1]
    turn_total = angle[-1] - angle[0] + (close + math.pi) % (2 * math.pi) - math.pi
    spacing = perimeter(loop) / n
    k = np.clip(np.ceil(widths.max(axis=1) / spacing).astype(np.int64), 1, max(n // 4, 1))
    index = np.arange(n)

    def unwrapped(at: np.ndarray) -> np.ndarray:  # the heading at ``at`` mod n, laps counted
        return np.asarray(angle[at % n] + (at // n) * turn_total)

    return np.asarray((unwrapped(index + k) - unwrapped(index - k)) / (2 * k * spacing))


def signed_area(loop: np.ndarray) -> float:
    """Shoelace area: positive for a counter-clockwise loop (y up)."""
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


class TooDense(ValueError):
    """A loop whose segments crowd one area so that the crossing check would not end soon."""


def self_intersection(loop: np.ndarray) -> tuple[int, int] | None:
    """The first pair (i, j), i < j, of non-adjacent segments that cross, or None.

    Segment i runs from point i to point i + 1. A uniform grid of cells about the median
    segment long: only segments whose bounding boxes share a cell are tested, so a loop of
    evenly spaced points costs O(N log N). Raises TooDense when more than
    ``MAX_CROSSING_PAIRS`` pairs share cells (segments piled into one area).
    """
    a, b = loop, np.roll(loop, -1, axis=0)
    low, high = np.minimum(a, b), np.maximum(a, b)
    first, second = _candidate_pairs(low, high)
    n = len(loop)
    apart = (second > first + 1) & ~((first == 0) & (second == n - 1))  # neighbours excluded
    first, second = first[apart], second[apart]
    boxes = (
        (low[first, 0] <= high[second, 0])
        & (low[second, 0] <= high[first, 0])
        & (low[first, 1] <= high[second, 1])
        & (low[second, 1] <= high[first, 1])
    )
    first, second = first[boxes], second[boxes]
    crossing = np.zeros(len(first), bool)
    for start in range(0, len(first), 1 << 20):  # bounded temporaries
        part = slice(start, start + (1 << 20))
        i, j = first[part], second[part]
        crossing[part] = _crosses(a[i], b[i], a[j], b[j])
    if not crossing.any():
        return None
    order = np.lexsort((second[crossing], first[crossing]))
    return int(first[crossing][order[0]]), int(second[crossing][order[0]])


def _candidate_pairs(low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(i, j), i < j, of segments whose bounding boxes may overlap: short segments by the
    cells of a uniform grid they share, each long one (over 8 cells) against all."""
    n = len(low)
    size = high - low
    extent = float(np.max(high.max(axis=0) - low.min(axis=0)))
    cell = max(2.0 * float(np.median(np.hypot(*size.T))), extent / n, 1e-300)
    long = np.flatnonzero(size.max(axis=1) > 8 * cell)
    if len(long) * n > MAX_CROSSING_PAIRS:
        raise TooDense(f"{len(long):,} of {n:,} segments are far longer than the others")
    short = np.setdiff1d(np.arange(n), long, assume_unique=True)
    first, second = _grid_pairs(low[short], high[short], cell)
    firsts, seconds = [short[first]], [short[second]]
    for k in long:  # a long segment's bounding box against every other one
        hit = np.flatnonzero(
            (low[:, 0] <= high[k, 0])
            & (low[k, 0] <= high[:, 0])
            & (low[:, 1] <= high[k, 1])
            & (low[k, 1] <= high[:, 1])
        )
        firsts.append(np.minimum(hit, k))
        seconds.append(np.maximum(hit, k))
    pairs = np.sort(np.concatenate(firsts) * np.int64(n) + np.concatenate(seconds))
    pairs = pairs[np.r_[True, pairs[1:] != pairs[:-1]]] if len(pairs) else pairs  # each once
    return pairs // n, pairs % n


def _grid_pairs(low: np.ndarray, high: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """(i, j), i < j, indices into ``low``/``high`` of boxes sharing a grid cell."""
    origin = low.min(axis=0) if len(low) else np.zeros(2)
    c0 = np.floor((low - origin) / cell).astype(np.int64)
    c1 = np.floor((high - origin) / cell).astype(np.int64)
    counts = (c1[:, 0] - c0[:, 0] + 1) * (c1[:, 1] - c0[:, 1] + 1)  # at most 9 x 9 cells
    owner = np.repeat(np.arange(len(low)), counts)
    rank = np.arange(len(owner)) - np.repeat(np.cumsum(counts) - counts, counts)
    width = np.repeat(c1[:, 0] - c0[:, 0] + 1, counts)
    cx = np.repeat(c0[:, 0], counts) + rank % width
    cy = np.repeat(c0[:, 1], counts) + rank // width
    key = cx * (int(c1[:, 1].max(initial=0)) + 2) + cy
    order = np.lexsort((owner, key))
    key, owner = key[order], owner[order]
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]) if len(key) else np.zeros(0, int)
    sizes = np.diff(np.r_[starts, len(key)])
    if int((sizes * (sizes - 1) // 2).sum()) > MAX_CROSSING_PAIRS:
        raise TooDense(f"more than {MAX_CROSSING_PAIRS:,} segment pairs crowd the same area")
    group_end = np.repeat(starts + sizes, sizes)
    firsts, seconds = [np.zeros(0, int)], [np.zeros(0, int)]
    at = np.arange(len(key))
    step = 1
    while len(at):  # owners are sorted within a cell: the pairs come out with i < j
        at = at[at + step < group_end[at]]
        firsts.append(owner[at])
        seconds.append(owner[at + step])
        step += 1
    return np.concatenate(firsts), np.concatenate(seconds)


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
