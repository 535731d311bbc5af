"""Compiled ray casting (numba): ``raycast_numpy.cast``'s ranges, bit for bit, one beam at a time.

Imported only when a lidar is built and numba imports (``pip install tinyrace[fast]``); see
``lidar.kernel``. The numpy passes find each beam's first blocked sample (its sample
offsets tabulated by ``raycast.beam_fan``; the coarse pass only skips segments that the NEAR
maps show hold none). This kernel finds the same sample without tables or NEAR maps: it
computes each sample's nearest cell with the same float64 arithmetic (the row's direction,
the origin's position inside its cell, the sample's radius), and from each free sample
skips as many samples as the field's skip map (a distance transform) shows cannot be
blocked. Beyond TABLE_RANGE it marches on by the same float32 sphere tracing and bisection
as ``raycast_numpy._beyond`` (a tip's nearest cell rounds half to even and saturates to int16, as
``cv2.remap`` does). Its field is made with ``distance_field(..., near=False)``, its fan
with ``beam_fan(..., tables=False)``.

numba compiles on the first scan of a process and caches the machine code beside this
module, or in numba's user cache directory when that is read-only; with neither writable
it compiles at every start, uncached. The compiled functions stay inside this module,
behind the typed ``cast``.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, TypeVar
from typing import cast as typed

import numpy as np
from numba import njit

from tinyrace.sensors import raycast
from tinyrace.sensors.raycast import (
    BISECTIONS,
    CHECK_EVERY,
    COARSE_STEP,
    FINE_SAMPLES,
    FINE_STEP,
    LEAD,
    MAX_ROUNDS,
    OVERSHOOT,
    SKIP_BLOCKED,
    TABLE_RANGE,
    DistanceField,
    Fan,
    start,
)

INT16 = (-32768, 32767)  # cv2.remap saturates map coordinates to int16
# numba's cache is keyed by this file alone, and the compiled code holds raycast's constants:
# they are spelled out here too, so that changing one there fails here until this file (and
# so the cache) changes as well
COMPILED_IN = {
    "BISECTIONS": 3, "CHECK_EVERY": 4, "FINE_STEP": 0.5, "LEAD": 146, "MAX_ROUNDS": 256,
    "OVERSHOOT": 2.0, "SKIP_BLOCKED": 255,
}  # fmt: skip
if any(getattr(raycast, name) != value for name, value in COMPILED_IN.items()):
    raise RuntimeError(f"raycast's constants changed: update COMPILED_IN ({COMPILED_IN})")
LANES = 16  # beams that step together (independent lookups the CPU overlaps)
F = TypeVar("F")


def _compile(function: F) -> F:
    """``function`` compiled, its machine code cached beside this module or in numba's
    user cache directory; uncached when neither is writable (numba refuses cache=True)."""
    try:
        return typed(F, njit(cache=True, nogil=True)(function))
    except RuntimeError as error:  # "cannot cache function ...: no locator available"
        warnings.warn(f"numba cannot cache the lidar kernel: {error}", stacklevel=1)
        return typed(F, njit(nogil=True)(function))


@_compile
def _nearest(steps: Any, x: Any, y: Any) -> Any:
    """float32 step [cells] in the cell nearest to (x, y) [cells], 0 off the map."""
    col = min(max(np.rint(x), INT16[0]), INT16[1])
    row = min(max(np.rint(y), INT16[0]), INT16[1])
    if 0 <= row < steps.shape[0] and 0 <= col < steps.shape[1]:
        return np.float32(steps[int(row), int(col)]) * np.float32(0.5)
    return np.float32(0.0)


@_compile
def _flat(x: float, y: float, width: int) -> Any:
    """Flat offset (plus LEAD rows) of the cell nearest to (x, y) [cells], unsigned: within
    TABLE_RANGE of the origin it is in the map (LEAD rows), and numba then skips the check
    for negative indices."""
    return np.uint64((math.floor(y + 0.5) + LEAD) * width + math.floor(x + 0.5))


@_compile
def _first_hits(
    skips: Any, width: int, sx: float, sy: float, cos: Any, sin: Any, top: int, samples: int,
    hits: Any,
) -> None:  # fmt: skip
    """``hits[b]``: index of the first blocked sample among the first ``samples`` of the
    beam of row top + b (origin shifted sx, sy [cells] from its cell, ``skips`` flat from
    that cell); -1 for none. Each free sample's cell tells how many next samples cannot be
    blocked. LANES beams step together: their lookups overlap instead of waiting in turn."""
    # every beam's first samples are as free as the origin's cell says: its skip (samples
    # (j + 1) FINE_STEP from the origin, which is within half a diagonal of its cell's centre)
    first = skips[LEAD * width]
    index = np.empty(LANES, np.int64)  # the next sample of each lane's beam
    c, s = np.empty(LANES), np.empty(LANES)
    for group in range(0, len(hits), LANES):
        lanes = min(LANES, len(hits) - group)
        for k in range(lanes):
            index[k], c[k], s[k] = first, cos[top + group + k], sin[top + group + k]
            hits[group + k] = -1
        going = lanes
        while going:
            going = 0
            for k in range(lanes):
                i = index[k]
                if i >= samples:
                    continue
                radius = (i + 1) * FINE_STEP
                skip = skips[_flat(sx + c[k] * radius, sy + s[k] * radius, width)]
                if skip == SKIP_BLOCKED:
                    hits[group + k], index[k] = i, samples
                else:
                    index[k] = i + 1 + skip
                    going += 1


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
    skips: Any, steps: Any, width: int, base: int, sx: float, sy: float, cos: Any, sin: Any,
    top: int, beams: int, samples: int, ranges: Any, past: Any, x: float, y: float,
    reach: tuple[float, float, float, float],
) -> Any:  # fmt: skip
    """float32 ranges [track units] of the beams of rows top .. top + beams - 1: ``ranges[i]``
    of each first blocked sample i, else ``past``; when ``past`` is inf, the march beyond
    the tables from the origin (x, y) [cells]. ``reach``: table range, limit [cells], cells
    per track unit, max range [track units] (float32 in the march, as in ``_beyond``)."""
    hits = np.empty(beams, np.int64)
    _first_hits(skips[base:], width, sx, sy, cos, sin, top, samples, hits)
    out = np.empty(beams, np.float32)
    ox, oy = np.float32(x), np.float32(y)
    table_range, limit = np.float32(reach[0]), np.float32(reach[1])
    per_unit, max_range = np.float32(reach[2]), np.float32(reach[3])
    for b in range(beams):
        out[b] = ranges[hits[b]] if hits[b] >= 0 else past
        if hits[b] < 0 and math.isinf(past):
            dx, dy = np.float32(cos[top + b]), np.float32(sin[top + b])
            t = _march(steps, ox, oy, dx, dy, table_range, limit)
            out[b] = min(t / per_unit, max_range)
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
    at = start(field, fan, origin, first)
    if at is None:
        return np.zeros(fan.beams, np.float32)
    steps = field.steps
    if steps is None:
        assert fan.table_range >= fan.limit, "distance_field(..., reach=...) past TABLE_RANGE"
        steps = _NO_STEPS
    reach = (fan.table_range, fan.limit, field.cells_per_unit, fan.max_range)
    samples = fan.segments * FINE_SAMPLES
    assert fan.segments * COARSE_STEP <= TABLE_RANGE < LEAD, "no sample leaves the map"
    out: np.ndarray = _scan(
        field.skips, steps, field.shape[1], at.base, fan.shifts[at.vx], fan.shifts[at.vy],
        fan.cos, fan.sin, at.top, fan.beams, samples, fan.ranges, fan.ranges[-1], at.x, at.y,
        reach,
    )  # fmt: skip
    return out[::-1] if reverse else out
