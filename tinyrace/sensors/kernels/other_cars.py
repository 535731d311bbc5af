"""Compiled beams against other cars (numba): ``other_cars.add_cars``'s ranges, bit for bit.

Imported by a lidar on the compiled path (``lidar.kernel``) when it rides in a race. The
plain path tests every beam against every other car (numpy over the beams, a pass per car);
this kernel tests a car only on the beams whose angle falls within the angle its footprint
spans from the origin (widened by two beams each side), since a ray from outside a convex
box meets it only between its corners' directions; a car farther than the lidar's range,
none. Each box and each tested beam is worked out with the plain path's float64 operations
in the same order (written out here again: numba's cache would not notice a change to a
function compiled from another file; numba compiles without fastmath, so without fused
multiply-adds), so the ranges are the same bits.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tinyrace.kernels.compiled import compiler
from tinyrace.sensors.machinery import other_cars

compiled = compiler("lidar")


@compiled
def _box(  # pragma: no cover  (compiled; its twin is other_cars.box)
    ox: Any, oy: Any, rx: Any, ry: Any, heading: Any, length: Any, width: Any
) -> Any:
    ax, ay = math.cos(heading), math.sin(heading)
    cx, cy = rx + ax * length / 2, ry + ay * length / 2
    dx, dy = ox - cx, oy - cy
    return dx * ax + dy * ay, dx * -ay + dy * ax, ax, ay, length / 2, width / 2


MARGIN = 2  # beams tested beyond each side of a footprint's angle
ALL_BEAMS = 3.0  # [rad] a footprint spanning more than this (the origin at it): every beam


@compiled
def _beam(  # pragma: no cover  (compiled; its twin is other_cars._distances)
    j: Any,
    ranges: Any,
    cos_a: Any,
    sin_a: Any,
    c: Any,
    s: Any,
    y_down: Any,
    sx: Any,
    sy: Any,
    ax: Any,
    ay: Any,
    half_length: Any,
    half_width: Any,
    max_range: Any,
) -> None:
    """Beam ``j`` against one footprint: its range lowered to the distance (at most
    ``max_range``), if it meets it."""
    if y_down:
        bx, by = c * cos_a[j] + s * sin_a[j], s * cos_a[j] - c * sin_a[j]
    else:
        bx, by = c * cos_a[j] - s * sin_a[j], s * cos_a[j] + c * sin_a[j]
    dx, dy = bx * ax + by * ay, bx * -ay + by * ax
    near, far = -math.inf, math.inf
    if dx == 0.0:  # along the slab: inside it, no limit (numpy's inf or NaN bounds)
        if abs(sx) > half_length:
            return
    else:
        low, high = (-half_length - sx) / dx, (half_length - sx) / dx
        near, far = min(low, high), max(low, high)
    if dy == 0.0:
        if abs(sy) > half_width:
            return
    else:
        low, high = (-half_width - sy) / dy, (half_width - sy) / dy
        near, far = max(near, min(low, high)), min(far, max(low, high))
    entry = near if near > 0.0 else 0.0  # np.maximum's +0.0 for a near of -0.0
    if far >= entry:
        distance = np.float32(min(entry, max_range))
        if distance < ranges[j]:
            ranges[j] = distance


@compiled
def _add_cars(  # pragma: no cover  (compiled; its twin is other_cars.add_cars)
    ranges: Any,
    ox: Any,
    oy: Any,
    heading: Any,
    y_down: Any,
    cos_a: Any,
    sin_a: Any,
    first: Any,
    step: Any,
    full: Any,
    rows: Any,
    max_range: Any,
) -> None:
    beams = ranges.shape[0]
    c, s = math.cos(heading), math.sin(heading)
    for k in range(rows.shape[0]):
        sx, sy, ax, ay, half_length, half_width = _box(
            ox, oy, rows[k, 0], rows[k, 1], rows[k, 2], rows[k, 3], rows[k, 4]
        )
        gap_x, gap_y = max(abs(sx) - half_length, 0.0), max(abs(sy) - half_width, 0.0)
        if math.hypot(gap_x, gap_y) > max_range * (1.0 + 1e-9) + 1e-9:
            continue  # every hit would be beyond the range: no range changes
        # the corners' directions as beam angles: the first corner's (in -pi..pi), and the
        # others' turns from it (in -pi..pi: from outside, a box spans less than pi)
        base, lowest, highest = 0.0, 0.0, 0.0
        for corner in range(4):
            along = half_length if corner < 2 else -half_length
            across = half_width if corner % 2 == 0 else -half_width
            px = (along - sx) * ax - (across - sy) * ay  # [track units] from the origin
            py = (along - sx) * ay + (across - sy) * ax
            angle = math.atan2(py, px) - heading
            if y_down:
                angle = -angle
            if corner == 0:
                base = (angle + math.pi) % (2 * math.pi) - math.pi
            else:
                turn = (angle - base + math.pi) % (2 * math.pi) - math.pi
                lowest, highest = min(lowest, turn), max(highest, turn)
        if (gap_x == 0.0 and gap_y == 0.0) or highest - lowest > ALL_BEAMS or beams < 8:
            for j in range(beams):  # at (or in) the box, or a fan too small to choose from
                _beam(j, ranges, cos_a, sin_a, c, s, y_down, sx, sy, ax, ay, half_length,
                      half_width, max_range)  # fmt: skip
            continue
        for shift in (-2.0 * math.pi, 0.0, 2.0 * math.pi):
            if full and shift != 0.0:
                continue  # the indices wrap round instead
            low = math.floor((base + lowest + shift - first) / step) - MARGIN
            high = math.ceil((base + highest + shift - first) / step) + MARGIN
            if not full:
                low, high = max(low, 0), min(high, beams - 1)
            for i in range(low, high + 1):
                _beam(i % beams, ranges, cos_a, sin_a, c, s, y_down, sx, sy, ax, ay,
                      half_length, half_width, max_range)  # fmt: skip


def add_cars(
    ranges: np.ndarray,
    origin: tuple[float, float],
    heading: float,
    y_down: bool,
    beam_fan: other_cars.BeamFan,
    rows: np.ndarray,
    max_range: float,
) -> np.ndarray:
    """``other_cars.add_cars``, compiled (the same arguments and ranges)."""
    lowered: np.ndarray = np.minimum(ranges, np.float32(max_range))  # as the plain path's
    f = beam_fan
    _add_cars(lowered, float(origin[0]), float(origin[1]), float(heading), bool(y_down), f.cos,
              f.sin, f.first, f.step, f.full, rows, float(max_range))  # fmt: skip
    return lowered
