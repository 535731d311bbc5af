"""Compiled ray casting (numba): ``raycast.cast``'s ranges, bit for bit, one beam at a time.

Imported only when a lidar is built and numba imports (``pip install tinyrace[fast]``); see
``lidar.kernel``. The numpy passes find each beam's first blocked sample (its sample
offsets tabulated by ``raycast.beam_fan``; the coarse pass only skips segments that the NEAR
maps show hold none). This kernel finds the same sample without tables or NEAR maps: it
computes each sample's nearest cell with the same float64 arithmetic (the row's direction,
the origin's position inside its cell, the sample's radius), and from each free sample
skips as many samples as the field's skip map (a distance transform) shows cannot be
blocked. Beyond TABLE_RANGE it marches on by the same float32 sphere tracing and bisection
as ``raycast._beyond`` (a tip's nearest cell rounds half to even and saturates to int16, as
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

from tinyrace.sensors.raycast import (
    BISECTIONS,
    CHECK_EVERY,
    FINE_SAMPLES,
    FINE_STEP,
    LEAD,
    MAX_ROUNDS,
    OVERSHOOT,
    SKIP_BLOCKED,
    DistanceField,
    Fan,
    start,
)

INT16 = (-32768, 32767)  # cv2.remap saturates map coordinates to int16
LANES = 16  # beams that step together (independent lookups the CPU overlaps)
F = TypeVar("F")


def _compile(function: F) -> F:
    """``function`` compiled, its machine code cached beside this module or in numba's
    user cache directory; uncached when neither is writable (numba refuses cache=True)."""
    try:
        return typed(F, njit(cache=True, nogil=True)(function))
    except RuntimeError as error:  # "cannot cache function ...: no locator available"
        warnings.warn(f"numba cannot cache the lidar kernel: {error}", stacklevel=2)
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
def _flat(x: float, y: float, width: int) -> int:
    """Flat offset (plus LEAD rows) of the cell nearest to (x, y) [cells]."""
    return (math.floor(y + 0.5) + LEAD) * width + math.floor(x + 0.5)


@_compile
def _first_hits(
    skips: Any, width: int, sx: float, sy: float, cos: Any, sin: Any, top: int, samples: int,
    hits: Any,
) -> None:  # fmt: skip
    """``hits[b]``: index of the first blocked sample among the first ``samples`` of the
    beam of row top + b (origin shifted sx, sy [cells] from its cell, ``skips`` flat from
    that cell); -1 for none. Each free sample's cell tells how many next samples cannot be
    blocked. LANES beams step together: their lookups overlap instead of waiting in turn."""
    last = len(skips) - 1  # np.take(mode="clip")
    index = np.empty(LANES, np.int64)  # the next sample of each lane's beam
    c, s = np.empty(LANES), np.empty(LANES)
    for group in range(0, len(hits), LANES):
        lanes = min(LANES, len(hits) - group)
        for k in range(lanes):
            index[k], c[k], s[k] = 0, cos[top + group + k], sin[top + group + k]
            hits[group + k] = -1
        going = lanes
        while going:
            going = 0
            for k in range(lanes):
                i = index[k]
                if i >= samples:
                    continue
                radius = (i + 1) * FINE_STEP
                skip = skips[min(_flat(sx + c[k] * radius, sy + s[k] * radius, width), last)]
                if skip == SKIP_BLOCKED:
                    hits[group + k], index[k] = i, samples
                else:
                    index[k] = i + 1 + skip
                    going += 1


@_compile
def _march(steps: Any, ox: Any, oy: Any, dx: Any, dy: Any, t: Any, limit: Any) -> Any:
    """float32 distance [cells] a beam from (ox, oy) in direction (dx, dy) travels from
    ``t`` by sphere tracing, checked every CHECK_EVERY rounds, then bisected back toward the
    edge of the blocking cell it entered (``raycast._march`` and ``_refine``, per beam)."""
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
    top: int, samples: int, ranges: Any, past: Any, origin: Any, reach: Any, out: Any,
) -> None:  # fmt: skip
    """Fill ``out`` [track units] with the ranges of the beams of rows top, top + 1, ...:
    ``ranges[i]`` of each first blocked sample i, else ``past``; when ``past`` is inf, the
    march beyond the tables. ``origin`` float32 (x, y) [cells]; ``reach`` float32 (table
    range, limit [cells], cells per unit, max range [track units])."""
    hits = np.empty(len(out), np.int64)
    _first_hits(skips[base:], width, sx, sy, cos, sin, top, samples, hits)
    for b in range(len(out)):
        out[b] = ranges[hits[b]] if hits[b] >= 0 else past
        if hits[b] < 0 and math.isinf(past):
            dx, dy = np.float32(cos[top + b]), np.float32(sin[top + b])
            t = _march(steps, origin[0], origin[1], dx, dy, reach[0], reach[1])
            out[b] = min(t / reach[2], reach[3])


_NO_STEPS = np.zeros((1, 1), np.uint8)  # the fans that never march beyond their tables


def cast(
    field: DistanceField,
    fan: Fan,
    origin: tuple[float, float],
    first: float,
    reverse: bool = False,
) -> np.ndarray:
    """``raycast.cast``, compiled: the same float32 ranges [track units], bit for bit; ``fan``
    needs no offset tables."""
    assert field.skips is not None, "distance_field(..., near=False)"
    at = start(field, fan, origin, first)
    out = np.zeros(fan.beams, np.float32)
    if at is None:
        return out
    steps = field.steps if field.steps is not None else _NO_STEPS
    beyond = fan.table_range < fan.limit
    assert not beyond or field.steps is not None, "distance_field(..., reach=...)"
    reach = np.array([fan.table_range, fan.limit, field.cells_per_unit, fan.max_range], np.float32)
    _scan(
        field.skips, steps, field.shape[1], at.base, fan.shifts[at.vx], fan.shifts[at.vy],
        fan.cos, fan.sin, at.top, fan.segments * FINE_SAMPLES, fan.ranges, fan.ranges[-1],
        np.array([at.x, at.y], np.float32), reach, out,
    )  # fmt: skip
    return out[::-1] if reverse else out
