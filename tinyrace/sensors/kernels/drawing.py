"""Compiled drawing of CarRacing's view (numba): the dashboard's bars and the car's blend.

Imported only when numba imports (a dependency of tinyrace); see
``tinyrace.sensors.machinery.drawing.kernel``. Each function gives the numpy path's pixels,
bit for bit:

- ``draw_bars``: the strip of ``Dashboard`` from its instruments' values. The numpy path
  draws each bar at ``factor`` x and area-averages it (cv2's ``INTER_AREA``), one layer
  per instrument, and takes their maximum. Here each output pixel's share of a bar is
  counted directly: cv2 averages an integer factor's block as its sum times the float32
  ``1 / factor**2``, rounded half to even, so the same count gives the same value.
- ``blend``: the car's patch over the frame, ``frame * weight + color`` in float32 and
  truncated to uint8, as numpy's same-type ufuncs compute it (no fastmath: no FMA).

numba compiles on first use and caches the machine code beside this module (or in
numba's user cache directory; uncached when neither is writable).
"""

from __future__ import annotations

import numpy as np

from tinyrace.kernels.compiled import compiler
from tinyrace.sensors.machinery.dashboard import (
    BAR_COLORS,
    BAR_PLACES,
    BAR_STEPS,
    BARS_VERTICAL,
    LAYOUT_UNITS,
)

compile_ = compiler("drawing")
_UNITS = float(LAYOUT_UNITS)  # as the numpy path divides by it


@compile_
def draw_bars(
    strip: np.ndarray, score: np.ndarray, shown: tuple[int, ...], height: int, factor: int
) -> None:
    """The dashboard's strip (``Dashboard.strip``'s pixels) into ``strip``: the ``score``
    layer, then each bar whose steps ``shown`` holds (in ``_BARS``'s order), by maximum.

    Every bar's box is cut to the strip before a pixel is written (compiled code checks
    no bounds); ``score`` has the strip's shape."""
    rows, width = strip.shape[0], strip.shape[1]
    flat, source = strip.reshape(-1), score.reshape(-1)
    for i in range(flat.size):  # (an element loop: numba's strip[...] = score is 8x slower)
        flat[i] = source[i]
    f = factor
    s, h = width / _UNITS * f, height / _UNITS * f
    bottom = rows * f  # the frame's bottom, in supersampled rows
    scale = np.float32(1.0) / np.float32(f * f)  # cv2's area factor, in float32
    for bar in range(len(BAR_PLACES)):
        steps = shown[bar]
        if steps == 0:
            continue
        value, place = steps / (BAR_STEPS * f), BAR_PLACES[bar]
        if BARS_VERTICAL[bar]:
            x0, y0, x1, y1 = place * s, bottom - h - h * value, (place + 1) * s, bottom - h
        else:
            x0, y0, x1, y1 = place * s, bottom - 4 * h, (place + value) * s, bottom - 2 * h
        xa, xb = min(x0, x1), max(x0, x1)
        first = max(int(xa // f), 0)
        last = min(int(np.ceil(xb / f)), width)
        patch = max(last - first, 1)  # output columns of the bar's patch
        # the box in supersampled pixels of the patch, cut to it as numpy slices cut
        col0, col1 = max(round(xa) - first * f, 0), min(max(round(xb) - first * f, 0), patch * f)
        row0, row1 = max(round(min(y0, y1)), 0), min(max(round(max(y0, y1)), 0), bottom)
        if col0 >= col1 or row0 >= row1:
            continue
        for r in range(row0 // f, (row1 - 1) // f + 1):
            tall = min(row1, r * f + f) - max(row0, r * f)
            for c in range(first + col0 // f, min(first + (col1 - 1) // f + 1, width)):
                wide = min(col1, (c - first) * f + f) - max(col0, (c - first) * f)
                for k in range(3):
                    shade = np.uint8(np.rint(np.float32(BAR_COLORS[bar, k] * tall * wide) * scale))
                    if shade > strip[r, c, k]:
                        strip[r, c, k] = shade


@compile_
def blend(image: np.ndarray, top: int, left: int, weight: np.ndarray, color: np.ndarray) -> None:
    """The patch whose corner is (``top``, ``left``) over ``image``: ``pixel * weight +
    color`` in float32, truncated to uint8 (``drawing.blend``'s pixels), in place.

    The patch must lie inside ``image`` (``car_sprite._clip`` cuts it so): compiled code
    checks no bounds."""
    rows, cols = weight.shape[0], weight.shape[1]
    for r in range(rows):
        for c in range(cols):
            for k in range(3):
                mixed = np.float32(image[top + r, left + c, k]) * weight[r, c, k] + color[r, c, k]
                image[top + r, left + c, k] = np.uint8(mixed)
