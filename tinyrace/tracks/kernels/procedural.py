"""Compiled tracing of CarRacing's track (numba): ``procedural.trace_path``, bit for bit.

Imported only when numba imports (a dependency of tinyrace); see
``procedural_source.trace_kernel``. numba compiles ``procedural.trace_loop`` itself, the
plain path's loop, on arrays: the C library's ``atan2``, ``cos`` and ``sin`` (which numba
calls as CPython's ``math`` does) and float64 arithmetic without fastmath (no reordering,
no fused multiply-add). The paths of 3,000 seeds are the same bit for bit on both paths
(``tests/test_track_procedural.py``).
"""

from __future__ import annotations

import numpy as np

from tinyrace.kernels.compiled import compiler
from tinyrace.tracks.procedural import (
    _MAX_STEPS,
    _START_RADIUS_FACTOR,
    ProceduralTrackParams,
    trace_loop,
)

_trace_loop = compiler("track")(trace_loop)


def trace_path(checkpoints: np.ndarray, params: ProceduralTrackParams) -> np.ndarray:
    """``procedural.trace_path``: rows (alpha, beta, x, y) of the path around the checkpoints."""
    alpha, x, y = (np.ascontiguousarray(column) for column in checkpoints.T)
    rows = np.empty(4 * _MAX_STEPS)
    start = _START_RADIUS_FACTOR * params.radius  # [u]
    points = _trace_loop(alpha, x, y, start, params.turn_rate, params.detail_step, rows)
    return rows[: 4 * points].reshape(-1, 4)
