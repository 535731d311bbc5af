"""Compiled tracing of CarRacing's track (numba): ``procedural.trace_path``, bit for bit.

Imported only when numba imports (``pip install tinyrace[fast]``); see
``procedural_source.trace_kernel``. The loop is the plain path's, operation for
operation: the C library's ``atan2``, ``cos`` and ``sin`` (which numba calls as CPython's
``math`` does), float64 arithmetic without fastmath (no reordering, no fused multiply-add).
The tracks of 3,000 seeds hash alike on both paths (``tests/test_track_procedural.py``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tinyrace.compiled import compiler
from tinyrace.tracks.procedural import (
    _MAX_LAPS,
    _MAX_STEPS,
    _START_RADIUS_FACTOR,
    _STEER_DEADBAND,
    _STEER_GAIN,
    _STEER_SCALE,
    ProceduralTrackParams,
)

_compile = compiler("track")


def trace_path(checkpoints: np.ndarray, params: ProceduralTrackParams) -> np.ndarray:
    """``procedural.trace_path``: rows (alpha, beta, x, y) of the path around the checkpoints."""
    alpha, x, y = (np.ascontiguousarray(column) for column in checkpoints.T)
    start = _START_RADIUS_FACTOR * params.radius
    return np.asarray(_trace(alpha, x, y, start, params.turn_rate, params.detail_step))


@_compile
def _trace(
    cp_alpha: Any, cp_x: Any, cp_y: Any, x: float, turn_rate: float, step: float
) -> Any:
    """The path from (``x``, 0) heading along +y; see ``procedural.trace_path``."""
    count = cp_alpha.shape[0]
    full_turn, unwrap_limit = 2 * math.pi, 1.5 * math.pi  # [rad]
    y, beta = 0.0, 0.0  # [u], [rad]
    target, laps, below_axis = 0, 0, False
    rows = np.empty((_MAX_STEPS, 4))
    points = 0
    for _ in range(_MAX_STEPS):
        alpha = math.atan2(y, x)
        if below_axis and alpha > 0:
            laps, below_axis = laps + 1, False
        if alpha < 0:
            below_axis, alpha = True, alpha + full_turn
        while alpha > cp_alpha[target]:
            target += 1
            if target == count:
                target, alpha = 0, alpha - full_turn
        cos_beta, sin_beta = math.cos(beta), math.sin(beta)
        proj = cos_beta * (cp_x[target] - x) + sin_beta * (cp_y[target] - y)
        while beta - alpha > unwrap_limit:
            beta -= full_turn
        while beta - alpha < -unwrap_limit:
            beta += full_turn
        prev_beta = beta
        proj *= _STEER_SCALE
        turn = abs(_STEER_GAIN * proj)
        if turn > turn_rate:
            turn = turn_rate
        if proj > _STEER_DEADBAND:
            beta -= turn
        elif proj < -_STEER_DEADBAND:
            beta += turn
        x, y = x - sin_beta * step, y + cos_beta * step
        rows[points, 0] = alpha
        rows[points, 1] = prev_beta * 0.5 + beta * 0.5
        rows[points, 2] = x
        rows[points, 3] = y
        points += 1
        if laps > _MAX_LAPS:
            break
    return rows[:points].copy()
