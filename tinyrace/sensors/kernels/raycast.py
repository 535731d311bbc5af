"""Compiled ray casting (numba): ``raycast_numpy.cast``'s ranges, bit for bit, one beam at a time.

Imported only when a lidar is built and numba imports (a dependency of tinyrace); see
``lidar.kernel``. The numpy passes find each beam's first blocked sample (its sample
offsets tabulated by ``raycast.beam_fan``; the coarse pass only skips segments that the NEAR
maps show hold none). This kernel finds the same sample without tables or NEAR maps: it
computes each sample's nearest cell with the same float64 arithmetic (the row's direction,
the origin's position inside its cell, the sample's radius), and from each free sample
skips as many samples as the field's skip map (a distance transform) shows cannot be
blocked, or, on fields that ``with_sectors`` gave skip maps by direction, the map of
the beam's sector (beams along a wall skip several times farther there). Beyond
TABLE_RANGE it marches on by the same float32 sphere tracing and bisection as
``raycast_numpy._beyond`` (a tip's nearest cell rounds half to even and saturates to
int16, as ``cv2.remap`` does). Its field is made with ``distance_field(..., near=False)``
and then ``with_sectors``, its fan with ``beam_fan(..., tables=False)``.

numba compiles on the first scan of a process and caches the machine code beside this
module, or in numba's user cache directory when that is read-only; with neither writable
it compiles at every start, uncached. The compiled functions stay inside this module,
behind the typed ``cast``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from tinyrace.kernels.compiled import compiler
from tinyrace.sensors.machinery import raycast
from tinyrace.sensors.machinery.raycast import (
    BISECTIONS,
    CHECK_EVERY,
    COARSE_STEP,
    FINE_SAMPLES,
    FINE_STEP,
    LEAD,
    MAX_ROUNDS,
    ORIGIN_STEPS,
    OVERSHOOT,
    SECTOR_SLOPES,
    SECTORS,
    SKIP_BLOCKED,
    SKIP_MARGIN,
    TABLE_RANGE,
    DistanceField,
    Fan,
)
from tinyrace.sensors.machinery.raycast_exact import EXACT_BLOCKED, LEAP_UNIT

INT16 = (-32768, 32767)  # cv2.remap saturates map coordinates to int16
# numba's cache is keyed by this file alone, and the compiled code holds raycast's constants:
# they are spelled out here too, so that changing one there fails here until this file (and
# so the cache) changes as well
COMPILED_IN = {
    "BISECTIONS": 3, "CHECK_EVERY": 4, "FINE_STEP": 0.5, "LEAD": 146, "MAX_ROUNDS": 256,
    "ORIGIN_STEPS": 3, "OVERSHOOT": 2.0, "SECTOR_SLOPES": 4, "SKIP_BLOCKED": 255,
}  # fmt: skip
if any(getattr(raycast, name) != value for name, value in COMPILED_IN.items()):
    raise RuntimeError(f"raycast's constants changed: update COMPILED_IN ({COMPILED_IN})")
LANES = 16  # beams that step together (independent lookups the CPU overlaps)
SECTOR_BYTES = 16 * 2**20  # [bytes] a field's sector maps at most (else its skip map serves)
# Large maps (the circuit's 1811 x 3151 cells) keep the one skip map. Measured against it on
# recorded poses: whole sector maps at scale 1 need 32x its bytes (174 MB there) for 9 % less
# time; sector maps kept only in the 16 x 16 tiles that hold free cells (11 MB there) took
# 20 % more time, the lookup through the tile table costing more than the 23 % fewer lookups
# sector map cells per cell and axis, finest first, as they fit in SECTOR_BYTES: powers of
# two, so that a scaled coordinate rounds as the coordinate does
SECTOR_SCALES = (2, 1)
RUN_CAP = 128  # [sector map cells] longest free run counted (its skips fill a uint8)
_compile = compiler("lidar")


@_compile
def _nearest(steps: Any, x: Any, y: Any) -> Any:
    """float32 step [cells] in the cell nearest to (x, y) [cells], 0 off the map."""
    col = min(max(np.rint(x), INT16[0]), INT16[1])
    row = min(max(np.rint(y), INT16[0]), INT16[1])
    if 0 <= row < steps.shape[0] and 0 <= col < steps.shape[1]:
        return np.float32(steps[int(row), int(col)]) * np.float32(0.5)
    return np.float32(0.0)


@_compile
def _flat(x: float, y: float, width: int, half: float) -> Any:
    """Flat offset of the cell nearest to (x, y) [cells, centres ``half`` a cell past
    integers], unsigned, modulo 2**64: added to LEAD rows it wraps into the map within
    TABLE_RANGE of the origin, and numba skips the check for negative indices."""
    return np.uint64(math.floor(y + half) * width + math.floor(x + half))


def with_sectors(field: DistanceField) -> DistanceField:
    """``field`` with its sector skip maps, as fine as fit in SECTOR_BYTES (none: the kernel
    uses the one skip map). A beam reads the map of its sector of directions (an eighth of a
    turn, split by the slope of the minor over the major axis in SECTOR_SLOPES steps), where
    a cell holds how many next samples of a beam in that sector, from any point of the cell,
    cannot be blocked: at least the skip map's, often several times more along walls (the
    skip map must allow for a wall on every side); cells smaller than the map's (``scale``
    of them per cell and axis) let a beam that grazes a wall come closer before it must
    look at every sample."""
    assert field.skips is not None, "distance_field(..., near=False)"
    height, width = field.shape
    fits = [s for s in SECTOR_SCALES if SECTORS * s * s * height * width <= SECTOR_BYTES]
    if not fits:
        return field
    scale = fits[0]
    lead = LEAD * width
    blocked, skips = (
        np.repeat(np.repeat(cells.reshape(height, width), scale, 0), scale, 1)
        for cells in (field.blocked[lead:-lead], field.skips[lead:-lead])
    )
    rows, cols = height * scale, width * scale
    lead = LEAD * scale * cols
    sectors = np.full(2 * lead + SECTORS * rows * cols, SKIP_BLOCKED, np.uint8)
    maps = sectors[lead : lead + SECTORS * rows * cols].reshape(SECTORS, rows, cols)
    clear = _clear(scale)
    for eighth in range(8):  # the kernels run along columns: (column, row) arrays
        turned, turned_skips = (
            np.ascontiguousarray(_canonical(a, eighth).T) for a in (blocked, skips)
        )
        prefix = np.zeros((turned.shape[0], turned.shape[1] + 1), np.int32)
        np.cumsum(turned, axis=1, out=prefix[:, 1:])
        out = np.empty_like(turned)
        for slope in range(SECTOR_SLOPES):
            _fill_sector(turned, prefix, turned_skips, out, slope, scale * FINE_STEP, clear)
            _canonical(maps[eighth * SECTOR_SLOPES + slope], eighth)[...] = out.T
    return dataclasses.replace(field, sectors=sectors, sector_scale=scale)


def _clear(scale: int) -> int:
    """The skip-map skip from which the first SECTOR_SLOPES bands (``_fill_sector``) of a
    sector map cell (1 / ``scale`` of a cell a side) are surely free: their map cells lie
    within hypot(m - 1, m + 1) / scale cells of it, and a map cell's centre within
    (1 - 1 / scale) / sqrt(2) of its cell's (for both ends); a skip n leaves no blocking
    cell's centre within n FINE_STEP + SKIP_MARGIN cells of the cell's."""
    m = SECTOR_SLOPES
    reach = math.hypot(m - 1, m + 1) / scale + (1 - 1 / scale) * math.sqrt(2)  # [cells]
    return math.floor((reach - SKIP_MARGIN) / FINE_STEP) + 1


def _canonical(cells: np.ndarray, eighth: int) -> np.ndarray:
    """A view of (H, w) ``cells`` turned so that the directions of ``eighth`` (bit 0: x < 0,
    bit 1: y < 0, bit 2: |y| > |x|) point along + columns (major) and + rows (minor)."""
    x_step, y_step = (-1 if eighth & 1 else 1), (-1 if eighth & 2 else 1)
    view: np.ndarray = cells.T[::x_step, ::y_step] if eighth & 4 else cells[::y_step, ::x_step]
    return view


@_compile
def _fill_sector(
    blocked: Any, prefix: Any, skips: Any, out: Any, slope: int, step: float, clear: int
) -> None:
    """``out``: the sector skips of (W, H) ``blocked`` cells (by column, then row) for beams
    pointing along + columns (cos c >= 0) and + rows (sin s, 0 <= s <= c) with slope s / c in
    [j / m, (j + 1) / m] (j = ``slope``, m = SECTOR_SLOPES); at least ``skips``, SKIP_BLOCKED
    where blocked. ``prefix[q, r]``: the blocking cells of column q above row r; ``step``:
    FINE_STEP in these cells; ``clear``: a skip from which the first m bands are free.

    Why it is safe. Let a sample lie in cell (r, q) (within half a cell of its centre on
    each axis) and a later one D = n step further, in cell (r + b, q + a). Then D c is
    in [a - 1, a + 1] and D s in [D c j / m, D c (j + 1) / m], so b is in the band
    [floor((a - 1) j / m) - 1, floor((a + 1) (j + 1) / m) + 1] (a cell of slack at each
    end for float rounding, which moves a sample by far less than 1e-6 cells and 1 / m).
    ``runs[q, r]`` counts the columns a = 0, 1, ... whose bands are free from (r, q). The
    band of (r, q) at column a >= m is the union of the bands of (r + j, q + m) and
    (r + j + 1, q + m) at column a - m: when the first m bands of (r, q) are free, its run
    is m + the smaller of their runs. A sample after n FINE_STEP lies in a column a <=
    1 + D c, below the run when D c < run - 1; and c <= m / hypot(m, j): any n with
    n step m / hypot(m, j) < run - 1 is safe. Where the run leaves the map, the map
    blocks; uint8 skips stop at SKIP_BLOCKED - 1 (runs at RUN_CAP).
    """
    width, height = blocked.shape
    m = SECTOR_SLOPES
    cos_max = m / math.hypot(m, slope)
    skip_of = np.empty(RUN_CAP + 1, np.uint8)  # [samples] by run [columns]
    for run in range(RUN_CAP + 1):
        free = math.floor((run - 1 - 1e-6) / (step * cos_max))  # 1e-6: float slack
        skip_of[run] = min(max(free, 0), SKIP_BLOCKED - 1)
    # the band a columns on: rows row + lo[a] .. row + hi[a]
    lo = np.array([(a - 1) * slope // m - 1 for a in range(m)])
    hi = np.array([(a + 1) * (slope + 1) // m + 1 for a in range(m)])
    runs = np.zeros((width, height), np.int32)  # [columns]
    for col in range(width - 1, -1, -1):
        for row in range(height):
            if blocked[col, row]:
                out[col, row] = SKIP_BLOCKED  # and run 0
                continue
            run = m if skips[col, row] >= clear else 0  # the first m bands are free
            while run < m and col + run < width and 0 <= row + lo[run] <= row + hi[run] < height:
                q, low, high = col + run, row + lo[run], row + hi[run] + 1
                if prefix[q, high] != prefix[q, low]:  # a blocking cell in the band
                    break
                run += 1
            if run == m and col + m < width and row + slope + 1 < height:
                ahead = min(runs[col + m, row + slope], runs[col + m, row + slope + 1])
                run = min(m + ahead, RUN_CAP)
            runs[col, row] = run
            out[col, row] = max(skips[col, row], skip_of[run])


@_compile
def _first_hits(
    skips: Any, rows: int, width: int, scale: int, sx: float, sy: float, cos: Any, sin: Any,
    sectors: Any, top: int, samples: int, hits: Any,
) -> None:  # fmt: skip
    """``hits[b]``: index of the first blocked sample among the first ``samples`` of the
    beam of row top + b (origin shifted sx, sy [cells] from its cell, ``skips`` flat from
    that cell); -1 for none. Each free sample's cell tells how many next samples cannot be
    blocked, in the skip map of the beam's sector (maps ``rows`` apart, 0: one map for all;
    ``scale`` map cells per cell and axis, a power of two: coordinates times ``scale``
    round exactly as the coordinates do, so a sample's map cell lies in its cell). Up to
    LANES beams of one sector step together: their lookups overlap instead of waiting."""
    index = np.empty(LANES, np.int64)  # the next sample of each lane's beam
    c, s = np.empty(LANES), np.empty(LANES)
    half, sx, sy = 0.5 * scale, sx * scale, sy * scale  # [map cells]
    lead = np.uint64(LEAD * scale * width)
    group = 0
    while group < len(hits):
        sector = sectors[top + group]
        lanes = 1
        while lanes < min(LANES, len(hits) - group) and (
            rows == 0 or sectors[top + group + lanes] == sector
        ):
            lanes += 1
        cells = skips[sector * rows * width :]  # the sector's map
        # the first samples are as free as the origin's cell says: its skip (samples
        # (j + 1) FINE_STEP from the origin, which lies in that cell)
        first = cells[lead + _flat(sx, sy, width, half)]
        for k in range(lanes):
            index[k], hits[group + k] = first, -1
            c[k], s[k] = cos[top + group + k] * scale, sin[top + group + k] * scale
        going = lanes
        while going:
            going = 0
            for k in range(lanes):
                i = index[k]
                if i >= samples:
                    continue
                radius = (i + 1) * FINE_STEP
                skip = cells[lead + _flat(sx + c[k] * radius, sy + s[k] * radius, width, half)]
                if skip == SKIP_BLOCKED:
                    hits[group + k], index[k] = i, samples
                else:
                    index[k] = i + 1 + skip
                    going += 1
        group += lanes


@_compile
def _march(steps: Any, ox: Any, oy: Any, dx: Any, dy: Any, t: Any, limit: Any) -> Any:
    """float32 distance [cells] a beam from (ox, oy) in direction (dx, dy) travels from
    ``t`` by sphere tracing, checked every CHECK_EVERY rounds, then bisected back toward the
    edge of the blocking cell it entered (``raycast_numpy._march`` and ``_refine``, per beam)."""
    px, py = ox + t * dx, oy + t * dy
    for round_ in range(MAX_ROUNDS):
        step = _nearest(steps, px, py)
        t += step
        px += step * dx
        py += step * dy
        if round_ % CHECK_EVERY == CHECK_EVERY - 1 and not (step > 0 and t < limit):
            break
    if _nearest(steps, ox + t * dx, oy + t * dy) != 0:
        return t
    low, high = max(t - np.float32(OVERSHOOT), np.float32(0.0)), t
    for _ in range(BISECTIONS):
        mid = (low + high) * np.float32(0.5)
        if _nearest(steps, ox + mid * dx, oy + mid * dy) == 0:
            high = mid
        else:
            low = mid
    return high


@_compile
def _scan(
    skips: Any, rows: int, steps: Any, blocked: Any, shape: tuple[int, int], scale: int,
    affine: tuple[float, float, float, float, float, float], origin: tuple[float, float],
    first: float, turning: tuple[float, float, int, int], shifts: Any, cos: Any, sin: Any,
    sectors: Any, beams: int, samples: int, ranges: Any, past: Any,
    reach: tuple[float, float, float, float],
) -> Any:  # fmt: skip
    """float32 ranges [track units] of the fan's beams from ``origin`` [track units], the
    first at angle ``first`` [rad] in the cell frame (``raycast.start`` with the same float64
    arithmetic: ``affine``, the field's; ``turning``: the fan's anchor [rad], step [rad],
    spacing and phase rows): ``ranges[i]`` of each first blocked sample i, else ``past``;
    when ``past`` is inf, the march beyond the tables from the origin. All 0 when the origin
    is off the map (``shape``, ``blocked`` flat with LEAD rows) or in a blocking cell.
    ``skips``: the skip map, or the sector maps ``rows`` apart (``scale`` cells of theirs
    per cell and axis). ``reach``: table range, limit [cells], cells per track unit, max
    range [track units] (float32 in the march, as in ``_beyond``)."""
    out = np.zeros(beams, np.float32)
    a, b, c, d, e, f = affine
    x, y = a * origin[0] + b * origin[1] + c, d * origin[0] + e * origin[1] + f  # [cells]
    col, row = math.floor(x + 0.5), math.floor(y + 0.5)
    height, width = shape
    if not (0 <= row < height and 0 <= col < width) or blocked[(LEAD + row) * width + col]:
        return out
    vx = min(int((x + 0.5 - col) * ORIGIN_STEPS), ORIGIN_STEPS - 1)
    vy = min(int((y + 0.5 - row) * ORIGIN_STEPS), ORIGIN_STEPS - 1)
    anchor, step, spacing, phase_rows = turning
    j = round(((first - anchor) % (2 * math.pi)) / step)
    top = (j % spacing) * phase_rows + j // spacing  # the first beam's row
    base = (row * width * scale + col) * scale  # the origin's cell in its map
    hits = np.empty(beams, np.int64)
    _first_hits(
        skips[base:], rows, width * scale, scale, shifts[vx], shifts[vy], cos, sin, sectors,
        top, samples, hits,
    )  # fmt: skip
    ox, oy = np.float32(x), np.float32(y)
    table_range, limit = np.float32(reach[0]), np.float32(reach[1])
    per_unit, max_range = np.float32(reach[2]), np.float32(reach[3])
    for i in range(beams):
        out[i] = ranges[hits[i]] if hits[i] >= 0 else past
        if hits[i] < 0 and math.isinf(past):
            dx, dy = np.float32(cos[top + i]), np.float32(sin[top + i])
            t = _march(steps, ox, oy, dx, dy, table_range, limit)
            out[i] = min(t / per_unit, max_range)
    return out


_NO_STEPS = np.zeros((1, 1), np.uint8)  # the fans that never march beyond their tables


def cast(
    field: DistanceField,
    fan: Fan,
    origin: tuple[float, float],
    first: float,
    reverse: bool = False,
) -> np.ndarray:
    """``raycast_numpy.cast``, compiled: the same float32 ranges [track units], bit for bit. The
    field needs its skip map (``distance_field(..., near=False)``), the fan no tables."""
    assert field.skips is not None, "distance_field(..., near=False)"
    steps = field.steps
    if steps is None:
        assert fan.table_range >= fan.limit, "distance_field(..., reach=...) past TABLE_RANGE"
        steps = _NO_STEPS
    assert fan.segments * COARSE_STEP <= TABLE_RANGE < LEAD, "no sample leaves the map"
    skips, rows, scale = field.skips, 0, 1
    if field.sectors is not None:  # the sector maps: scale cells of theirs per cell
        scale = field.sector_scale
        skips, rows = field.sectors, field.shape[0] * scale
    out: np.ndarray = _scan(
        skips, rows, steps, field.blocked, field.shape, scale, field.affine, origin, first,
        (fan.anchor, fan.step, fan.spacing, fan.phase_rows), fan.shifts, fan.cos, fan.sin,
        fan.sectors, fan.beams, fan.segments * FINE_SAMPLES, fan.ranges, fan.ranges[-1],
        (fan.table_range, fan.limit, field.cells_per_unit, fan.max_range),
    )  # fmt: skip
    return out[::-1] if reverse else out


@_compile
def _exact(cells: Any, ox: float, oy: float, dx: Any, dy: Any, limit: float) -> Any:
    """``raycast_numpy.cast_exact``'s rounds, beam by beam (the same float64 arithmetic).
    LANES beams step in turn, so that their lookups (most of them cache misses: a leap lands
    far away) overlap instead of waiting one after the other."""
    height, width = cells.shape
    beams = len(dx)
    out = np.zeros(beams, np.float64)
    col, row = math.floor(ox + 0.5), math.floor(oy + 0.5)
    if not (0 <= row < height and 0 <= col < width) or cells[row, col] == EXACT_BLOCKED:
        return out
    t, tmx, tmy = np.empty(LANES), np.empty(LANES), np.empty(LANES)
    inv_x, inv_y = np.empty(LANES), np.empty(LANES)
    half_x, half_y = np.empty(LANES), np.empty(LANES)
    ix, iy = np.empty(LANES, np.int64), np.empty(LANES, np.int64)
    step_x, step_y = np.empty(LANES, np.int64), np.empty(LANES, np.int64)
    leap = np.empty(LANES, np.int64)
    for group in range(0, beams, LANES):
        lanes = min(LANES, beams - group)
        for k in range(lanes):
            cx, cy = dx[group + k], dy[group + k]
            half_x[k] = 0.5 if cx > 0 else -0.5
            half_y[k] = 0.5 if cy > 0 else -0.5
            step_x[k] = 1 if cx > 0 else -1
            step_y[k] = 1 if cy > 0 else -1
            inv_x[k] = 1.0 / cx if cx != 0 else np.inf
            inv_y[k] = 1.0 / cy if cy != 0 else np.inf
            ix[k], iy[k], t[k] = col, row, 0.0
            tmx[k] = ((col + half_x[k]) - ox) * inv_x[k] if cx != 0 else np.inf
            tmy[k] = ((row + half_y[k]) - oy) * inv_y[k] if cy != 0 else np.inf
            leap[k] = cells[row, col]
        going = lanes
        while going:
            going = 0
            for k in range(lanes):
                if leap[k] < 0:  # done
                    continue
                cx, cy = dx[group + k], dy[group + k]
                if leap[k] > 0:
                    t[k] = t[k] + leap[k] / LEAP_UNIT
                    ix[k] = math.floor((ox + t[k] * cx) + 0.5)
                    iy[k] = math.floor((oy + t[k] * cy) + 0.5)
                    tmx[k] = ((ix[k] + half_x[k]) - ox) * inv_x[k] if cx != 0 else np.inf
                    tmy[k] = ((iy[k] + half_y[k]) - oy) * inv_y[k] if cy != 0 else np.inf
                elif tmx[k] < tmy[k]:
                    t[k] = tmx[k]
                    ix[k] += step_x[k]
                    tmx[k] = ((ix[k] + half_x[k]) - ox) * inv_x[k]
                else:
                    t[k] = tmy[k]
                    iy[k] += step_y[k]
                    tmy[k] = ((iy[k] + half_y[k]) - oy) * inv_y[k] if cy != 0 else np.inf
                found = cells[iy[k], ix[k]]
                if t[k] >= limit:
                    out[group + k], leap[k] = limit, -1
                elif found == EXACT_BLOCKED:
                    out[group + k], leap[k] = t[k], -1
                else:
                    leap[k] = found
                    going += 1
    return out


def cast_exact(
    cells: np.ndarray,
    origin: tuple[float, float],
    dx: np.ndarray,
    dy: np.ndarray,
    limit: float,
) -> np.ndarray:
    """``raycast_numpy.cast_exact``, compiled: the same float64 distances [cells], bit for bit."""
    out: np.ndarray = _exact(cells, origin[0], origin[1], dx, dy, float(limit))
    return out
