"""The numpy path of ray casting: two vectorised passes over a fan's sample tables.

A scan takes two gathers, whatever the heading and the walls: a coarse pass samples the
middle of every COARSE_STEP segment of every beam in its direction's NEAR map and finds each
beam's first flagged segment; a fine pass samples that segment every FINE_STEP in the
blocking map and finds the first blocked sample. Beams whose flagged segment only passed
blocking cells by (false alarms) go on to their next flagged segment while they are many,
and sample their whole row when few. Beyond TABLE_RANGE, beams march on by sphere tracing.
The field and the fan (``raycast``) must be made for this path: ``distance_field(...,
near=True)`` and ``beam_fan(..., tables=True)``. ``kernels/raycast.py`` gives the same ranges.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from tinyrace.sensors.machinery.raycast import (
    BISECTIONS,
    CHECK_EVERY,
    FINE_SAMPLES,
    MAX_ROUNDS,
    ORIGIN_STEPS,
    OVERSHOOT,
    DistanceField,
    Fan,
    start,
)
from tinyrace.sensors.machinery.raycast_exact import EXACT_BLOCKED, LEAP_UNIT

FEW = 48  # beams with false alarms so few that sampling their whole rows is cheaper
# (b0 + b1 * 2^8 + ... + b7 * 2^56) * PACK >> 56 has bit i = b_i when every b_i is 0 or 1
PACK = np.uint64(0x0102040810204080)
# FIRST[lo + 256 * hi]: index of the first 1 among the 16 bits of two packed bytes; 16: none
_LOWEST = np.arange(1 << 16) & -np.arange(1 << 16)  # the lowest set bit of each index
FIRST = np.where(_LOWEST > 0, np.log2(np.maximum(_LOWEST, 1)), 16).astype(np.int64)


def cast(
    field: DistanceField,
    fan: Fan,
    origin: tuple[float, float],
    first: float,
    reverse: bool = False,
) -> np.ndarray:
    """Ranges [track units] (float32) of ``fan``'s beams from ``origin`` [track units], the
    first beam at angle ``first`` [rad] in the cell frame and each next one ``spacing`` rows
    further counter-clockwise; ``reverse``: return them last first (see ``fan_angle``).

    A beam that hits nothing within max_range returns max_range; a beam that starts in a
    blocking cell (or off the map) returns 0. The fan turns in steps of ``fan.step`` (to the
    nearest). The numpy path: ``fan`` needs its tables (``beam_fan(..., tables=True)``).
    """
    at = start(field, fan, origin, first)
    if at is None:
        return np.zeros(fan.beams, np.float32)
    rows = slice(at.top, at.top + fan.beams)
    ranges = _passes(field, fan, at.base, at.vx * ORIGIN_STEPS + at.vy, rows)
    if fan.table_range < fan.limit:
        ranges = _beyond(field, fan, (at.x, at.y), rows, ranges)
    return ranges[::-1] if reverse else ranges


def _passes(field: DistanceField, fan: Fan, base: int, variant: int, rows: slice) -> np.ndarray:
    """[track units] range of each beam within the tables (past them: inf, or max_range when
    the tables reach it), from the origin cell ``base``
    (flat, padded map), its ``variant`` and the table ``rows`` of the beams."""
    assert fan.coarse is not None and fan.fine is not None, "beam_fan(..., tables=True)"
    assert field.near is not None, "distance_field(..., near=True)"
    near, blocked = field.near[base:], field.blocked[base:]
    flags = near.take(fan.coarse[variant, rows], mode="clip")
    np.bitwise_and(flags, fan.bits[rows], out=flags)
    flags = flags != 0
    segment = np.minimum(_first(flags), fan.segments)  # first flagged; segments if none
    fine = fan.fine[variant, rows]  # (B, (segments + 2) * FINE_SAMPLES)
    per_row = fan.segments + 2
    windows = fine.reshape(-1, FINE_SAMPLES)
    t = _window(blocked, fan, windows, segment, fan.beam_windows)
    missed = np.flatnonzero(t < 0)
    while len(missed) > FEW:  # false alarms: on to the beam's next flagged segment
        flags[missed, segment[missed]] = False
        segment[missed] = np.minimum(_first(flags[missed]), fan.segments)
        t[missed] = _window(blocked, fan, windows, segment[missed], missed * per_row)
        missed = missed[t[missed] < 0]
    if len(missed):  # the rest of the row decides
        hit = blocked.take(fine.take(missed, 0), mode="clip").argmax(1)  # at worst FAR: inf
        t[missed] = fan.ranges.take(hit)
    return t


def _window(
    blocked: np.ndarray, fan: Fan, windows: np.ndarray, segment: np.ndarray, starts: np.ndarray
) -> np.ndarray:
    """The fine pass over one ``segment`` of each beam (its windows from ``starts``): range
    [track units]; -1 for a false alarm (no hit in a flagged segment)."""
    samples = blocked.take(windows.take(segment + starts, 0), mode="clip")  # (n, FINE_SAMPLES)
    found: np.ndarray = fan.found.take(segment * (FINE_SAMPLES + 1) + _first(samples))
    return found


def _first(rows: np.ndarray) -> np.ndarray:
    """Index of the first 1 in each row of an (n, 16) array of 0/1 bytes (16: none), from
    the rows' two uint64 words packed into bits: no loop over rows."""
    packed = (np.ascontiguousarray(rows).view(np.uint64) * PACK) >> np.uint64(56)
    index: np.ndarray = FIRST.take(packed[:, 0] | (packed[:, 1] << np.uint64(8)))
    return index


def _beyond(
    field: DistanceField, fan: Fan, origin: tuple[float, float], rows: slice, t: np.ndarray
) -> np.ndarray:
    """``t`` [track units] with the beams that hit nothing within the tables (inf) marched
    on by sphere tracing from the tables' end to the fan's limit."""
    assert field.steps is not None, "distance_field(..., reach=...) past TABLE_RANGE"
    far = np.flatnonzero(np.isinf(t))
    if len(far) == 0:
        return t
    index = far + rows.start
    dx, dy = fan.cos[index].astype(np.float32), fan.sin[index].astype(np.float32)
    start = np.array(origin, np.float32)
    reached = np.full(len(far), fan.table_range, np.float32)
    reached = _march(field.steps, start, dx, dy, reached, np.float32(fan.limit))
    cells = _refine(field.steps, start, dx, dy, reached)
    # clipped after the division: limit / cells_per_unit may round past max_range in float32
    t[far] = np.minimum(cells / np.float32(field.cells_per_unit), np.float32(fan.max_range))
    return t


def _march(
    steps: np.ndarray,
    start: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    t: np.ndarray,
    limit: np.float32,
) -> np.ndarray:
    """Distance [cells] each beam travels, from ``t``, before it stops in a blocking cell or
    passes ``limit``. Every CHECK_EVERY rounds the beams that stopped leave the working arrays."""
    t_all: np.ndarray = t.copy()
    index = np.arange(len(dx))
    px, py = start[0] + t * dx, start[1] + t * dy
    for round_ in range(MAX_ROUNDS):
        step = _sample(steps, px, py)
        t += step
        px += step * dx
        py += step * dy
        if round_ % CHECK_EVERY == CHECK_EVERY - 1:
            going = (step > 0) & (t < limit)
            if not going.all():
                t_all[index] = t
                index, t, px, py = index[going], t[going], px[going], py[going]
                dx, dy = dx[going], dy[going]
                if len(index) == 0:
                    return t_all
    t_all[index] = t
    return t_all


def _sample(steps: np.ndarray, px: np.ndarray, py: np.ndarray) -> np.ndarray:
    """The step [cells] in the cell under each tip (nearest cell); 0 outside the map."""
    found = cv2.remap(steps, px[None], py[None], cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT)
    step: np.ndarray = found[0] * np.float32(0.5)
    return step


def _refine(
    steps: np.ndarray, start: np.ndarray, dx: np.ndarray, dy: np.ndarray, t: np.ndarray
) -> np.ndarray:
    """Bisect each hit back toward the edge of the blocking cell it entered: a tip overshoots
    an edge by less than OVERSHOOT cells."""
    blocked = _sample(steps, start[0] + t * dx, start[1] + t * dy) == 0
    low = np.where(blocked, np.maximum(t - OVERSHOOT, 0), t)
    high = t
    for _ in range(BISECTIONS):
        mid = (low + high) * np.float32(0.5)
        hit = _sample(steps, start[0] + mid * dx, start[1] + mid * dy) == 0
        high = np.where(hit, mid, high)
        low = np.where(hit, low, mid)
    refined: np.ndarray = np.where(blocked, high, t)
    return refined


def cast_exact(
    cells: np.ndarray,
    origin: tuple[float, float],
    dx: np.ndarray,
    dy: np.ndarray,
    limit: float,
) -> np.ndarray:
    """float64 distance [cells] from ``origin`` [cells] along each unit direction (dx, dy)
    [cells] to the edge of the first blocking cell of an exact field's ``cells`` (H, w)
    (squares centred on integer coordinates; ``raycast_exact.ExactField``), at most ``limit``; 0
    for every beam when the origin is off the map or in a blocking cell. An Amanatides-Woo
    traversal, vectorised over the beams: each round, a beam in a free cell with a leap
    leaps, the others step into the next cell their line crosses;
    ``sensors.kernels.raycast.cast_exact`` does the same rounds beam by beam, with the same float64
    arithmetic."""
    ox, oy = origin
    height, width = cells.shape
    beams = len(dx)
    out = np.zeros(beams, np.float64)
    col, row = math.floor(ox + 0.5), math.floor(oy + 0.5)
    if not (0 <= row < height and 0 <= col < width) or cells[row, col] == EXACT_BLOCKED:
        return out
    half_x = np.where(dx > 0, 0.5, -0.5)
    half_y = np.where(dy > 0, 0.5, -0.5)
    step_x = np.where(dx > 0, 1, -1)
    step_y = np.where(dy > 0, 1, -1)
    with np.errstate(divide="ignore"):
        inv_x, inv_y = 1.0 / dx, 1.0 / dy
    index = np.arange(beams)
    t = np.zeros(beams)
    ix, iy = np.full(beams, col, np.int64), np.full(beams, row, np.int64)
    tmx = _edge(ix, half_x, ox, dx, inv_x)
    tmy = _edge(iy, half_y, oy, dy, inv_y)
    leap = cells[iy, ix]
    while len(index):
        jump = leap > 0
        along_x = ~jump & (tmx < tmy)
        along_y = ~jump & ~along_x
        t = np.where(jump, t + leap / LEAP_UNIT, np.where(along_x, tmx, tmy))
        if jump.any():
            j = np.flatnonzero(jump)
            ix[j] = np.floor((ox + t[j] * dx[index[j]]) + 0.5).astype(np.int64)
            iy[j] = np.floor((oy + t[j] * dy[index[j]]) + 0.5).astype(np.int64)
        ix += np.where(along_x, step_x[index], 0)
        iy += np.where(along_y, step_y[index], 0)
        moved_x, moved_y = jump | along_x, jump | along_y
        gx, gy = index[moved_x], index[moved_y]
        tmx[moved_x] = _edge(ix[moved_x], half_x[gx], ox, dx[gx], inv_x[gx])
        tmy[moved_y] = _edge(iy[moved_y], half_y[gy], oy, dy[gy], inv_y[gy])
        leap = cells[iy, ix]
        far = t >= limit
        stop = far | (leap == EXACT_BLOCKED)
        if stop.any():
            out[index[stop]] = np.where(far[stop], limit, t[stop])
            keep = ~stop
            index, t, ix, iy, tmx, tmy, leap = (a[keep] for a in (index, t, ix, iy, tmx, tmy, leap))
    return out


def _edge(
    i: np.ndarray, half: np.ndarray, o: float, d: np.ndarray, inverse: np.ndarray
) -> np.ndarray:
    """[cells] along each beam from the origin ``o`` to the far edge of its cell ``i`` on
    one axis (direction ``d``, ``inverse`` 1 / d; inf when d is 0)."""
    edge: np.ndarray = np.where(d != 0, ((i + half) - o) * np.where(d != 0, inverse, 1.0), np.inf)
    return edge
