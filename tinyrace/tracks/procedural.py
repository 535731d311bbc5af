"""CarRacing-v3's procedural track, drawn from the same random numbers.

A track is made in five steps: random checkpoints on a rough circle, a path
steered through them for several laps, one clean lap cut out of that path,
red/white kerbs on the hard turns, and one road tile per lap point. Given the
same ``numpy.random.Generator`` state, :func:`generate_track` returns the
track CarRacing-v3 builds after ``reset`` (tiles and kerbs within 1e-6 u).

Pure numpy: no physics, no drawing, no gymnasium (the track source that reads the
config is ``tinyrace.tracks.procedural_source``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

# Fixed parts of CarRacing's steering law, kept apart from the tunable params.
# The law reads the projection in Box2D units (world units times SCALE = 6),
# so its dead band and gain are stated in those units to keep the same floats.
_STEER_SCALE = 6.0  # [Box2D units / u]
_STEER_DEADBAND = 0.3  # [Box2D units] no turn while |projection| is below this
_STEER_GAIN = 0.001  # [rad / Box2D unit] turn per unit of projection, before the rate cap
_START_RADIUS_FACTOR = 1.5  # first and last checkpoints sit at 1.5 * radius
_MAX_LAPS = 4  # the path stops once it has completed more laps than this
_MAX_STEPS = 2500  # hard cap on path points
_KERB_TURN_FRACTION = 0.2  # a hard turn steps by more than this fraction of turn_rate
_MIN_LAP_POINTS = 3  # fewer is no track (extreme knobs); CarRacing's own knobs never get there


class NoClosedLap(RuntimeError):
    """The generator found no closed lap within ``max_attempts``."""


@dataclass(frozen=True)
class ProceduralTrackParams:
    """Knobs of the CarRacing generator; the defaults reproduce CarRacing-v3."""

    checkpoints: int = 12
    radius: float = 900 / 6  # TRACK_RAD [u]
    half_width: float = 40 / 6  # TRACK_WIDTH, half the road width [u]
    turn_rate: float = 0.31  # [rad] max heading change per detail step
    detail_step: float = 21 / 6  # [u]
    border: float = 8 / 6  # kerb width [u]
    border_min_count: int = 4  # kerbs need this many sharp same-way steps in a row
    # Regeneration attempts before raising RuntimeError (CarRacing retries forever; we cap).
    max_attempts: int = 100


@dataclass(frozen=True, eq=False)
class ProceduralTrack:
    """One generated lap; arrays are read-only."""

    # (N, 2) float64, track points in order, point 0 first (the car's start point) [u]
    centerline: np.ndarray
    # (N,) float64, beta of each point [rad] (the car's hull angle at the start is headings[0])
    headings: np.ndarray
    # (N, 4, 2) float64, tile i = quad between points i-1 and i, vertices in CarRacing's order [u]
    tiles: np.ndarray
    kerbs: np.ndarray  # (K, 4, 2) float64 kerb quads [u] (K may be 0)
    kerb_red: np.ndarray  # (K,) bool, True for red kerb quads, False for white
    attempts: int  # how many generation attempts were needed (>= 1)

    @property
    def start_pose(self) -> tuple[float, float, float]:
        """Where the car starts: (x [u], y [u], hull angle [rad])."""
        x, y = self.centerline[0]
        return float(x), float(y), float(self.headings[0])


def generate_track(
    rng: np.random.Generator,
    params: ProceduralTrackParams = ProceduralTrackParams(),
    trace: Callable[[np.ndarray, ProceduralTrackParams], np.ndarray] | None = None,
) -> ProceduralTrack:
    """Draw a CarRacing track from rng; same draws, same track as CarRacing-v3.

    Each attempt draws ``2 * params.checkpoints`` uniforms. An attempt fails when
    its lap does not close; like CarRacing, the next attempt draws afresh from
    the same rng. Raises RuntimeError after ``params.max_attempts`` failures.
    ``trace``: the path's tracer, ``trace_path`` or its compiled twin (same rows).
    """
    trace = trace or trace_path
    for attempt in range(1, params.max_attempts + 1):
        checkpoints = _draw_checkpoints(rng, params)
        lap = _extract_lap(trace(checkpoints, params), params)
        if lap is not None:
            return _build_track(lap, params, attempt)
    raise NoClosedLap(
        f"no closed track after {params.max_attempts} attempts; "
        "raise max_attempts or check radius, detail_step and turn_rate"
    )


def _draw_checkpoints(rng: np.random.Generator, params: ProceduralTrackParams) -> np.ndarray:
    """Checkpoints as rows (alpha [rad], x [u], y [u]), counter-clockwise from alpha 0.

    Draws (noise, radius) per checkpoint, in that order; the first and last
    checkpoints are then pinned to the start line's radius.
    """
    n = params.checkpoints
    sector = 2 * math.pi / n  # [rad]
    draws = rng.uniform((0.0, params.radius / 3), (sector, params.radius), size=(n, 2))
    alpha = 2 * math.pi * np.arange(n) / n + draws[:, 0]
    rad = draws[:, 1]
    alpha[0], rad[0] = 0.0, _START_RADIUS_FACTOR * params.radius
    alpha[-1], rad[-1] = 2 * math.pi * (n - 1) / n, _START_RADIUS_FACTOR * params.radius
    return np.column_stack((alpha, rad * np.cos(alpha), rad * np.sin(alpha)))


def trace_path(checkpoints: np.ndarray, params: ProceduralTrackParams) -> np.ndarray:
    """Steer from the start line towards the checkpoints for a few laps.

    Returns rows (alpha [rad], beta [rad], x [u], y [u]): the point's polar
    angle (shifted by 2*pi past the last checkpoint), the mean heading over the
    step, and the point reached.

    This loop is most of a reset's track generation, so it is one flat loop over
    Python floats (no calls but math's): each step depends on the one before, so
    numpy cannot help. The arithmetic is CarRacing's, operation for operation.
    """
    cp_alpha, cp_x, cp_y = (column.tolist() for column in checkpoints.T)
    rows = [0.0] * (4 * _MAX_STEPS)
    start = _START_RADIUS_FACTOR * params.radius  # [u]
    points = trace_loop(cp_alpha, cp_x, cp_y, start, params.turn_rate, params.detail_step, rows)
    return np.array(rows[: 4 * points]).reshape(-1, 4)


def trace_loop(
    cp_alpha: Any, cp_x: Any, cp_y: Any, x: float, turn_rate: float, step: float, rows: Any
) -> int:
    """``trace_path``'s loop from (``x``, 0) heading along +y: fills ``rows`` (flat: alpha,
    beta, x, y per point) and returns the number of points.

    Written for Python lists and numpy arrays alike: numba compiles this same function
    (``kernels/procedural.py``), where the checkpoints and ``rows`` are arrays.
    """
    count = len(cp_alpha)
    full_turn, unwrap_limit = 2 * math.pi, 1.5 * math.pi  # [rad]
    atan2, cos, sin = math.atan2, math.cos, math.sin
    y, beta = 0.0, 0.0  # [u], [rad]
    target, laps, below_axis = 0, 0, False  # target: index of the checkpoint aimed at
    points = 0
    for _ in range(_MAX_STEPS):
        alpha = atan2(y, x)  # [rad]
        if below_axis and alpha > 0:
            laps, below_axis = laps + 1, False
        if alpha < 0:
            below_axis, alpha = True, alpha + full_turn
        # aim at the first checkpoint not behind alpha; past the last one, wrap to the first
        while alpha > cp_alpha[target]:
            target += 1
            if target == count:
                target, alpha = 0, alpha - full_turn
        cos_beta, sin_beta = cos(beta), sin(beta)
        proj = cos_beta * (cp_x[target] - x) + sin_beta * (cp_y[target] - y)  # [u]
        # unwrap beta to within 1.5*pi of alpha
        while beta - alpha > unwrap_limit:
            beta -= full_turn
        while beta - alpha < -unwrap_limit:
            beta += full_turn
        prev_beta = beta
        # steer towards the target: the law reads the projection in Box2D units
        proj *= _STEER_SCALE
        turn = abs(_STEER_GAIN * proj)  # [rad]
        if turn > turn_rate:
            turn = turn_rate
        if proj > _STEER_DEADBAND:
            beta -= turn
        elif proj < -_STEER_DEADBAND:
            beta += turn
        # the step runs along the heading's normal, using the heading before this turn
        x, y = x - sin_beta * step, y + cos_beta * step
        at = 4 * points
        rows[at], rows[at + 1], rows[at + 2], rows[at + 3] = (
            alpha, prev_beta * 0.5 + beta * 0.5, x, y,
        )  # fmt: skip
        points += 1
        if laps > _MAX_LAPS:
            break
    return points


def _extract_lap(path: np.ndarray, params: ProceduralTrackParams) -> np.ndarray | None:
    """Cut the last full lap out of the path, or None if it does not close.

    The lap runs from the second-to-last crossing of the start angle up to
    two points before the last crossing.
    """
    start_alpha = -math.pi / params.checkpoints  # [rad] half a sector before alpha 0
    alpha = path[:, 0]
    crossings = np.flatnonzero((alpha[1:] > start_alpha) & (alpha[:-1] <= start_alpha)) + 1
    if len(crossings) < 2:
        return None
    lap = path[crossings[-2] : crossings[-1] - 1]
    if len(lap) < _MIN_LAP_POINTS:
        return None
    return lap if _seam_gap(lap) <= params.detail_step else None


def _seam_gap(lap: np.ndarray) -> float:
    """Distance [u] between the lap's last and first points, as CarRacing measures it.

    Each coordinate of the gap is weighted by the matching component of the
    first heading's unit vector (not a dot product), then combined as a norm.
    """
    beta0 = lap[0, 1]
    dx, dy = lap[0, 2:4] - lap[-1, 2:4]
    return math.hypot(math.cos(beta0) * dx, math.sin(beta0) * dy)


def _build_track(lap: np.ndarray, params: ProceduralTrackParams, attempts: int) -> ProceduralTrack:
    """Turn a closed lap's rows (alpha, beta, x, y) into tiles and kerbs."""
    centerline, headings = lap[:, 2:4].copy(), lap[:, 1].copy()
    normals = np.column_stack((np.cos(headings), np.sin(headings)))
    every = np.arange(len(lap))
    tiles = _quads(centerline, normals, every, -params.half_width, params.half_width)
    kerbs, kerb_red = _kerbs(centerline, headings, normals, params)
    arrays = (centerline, headings, tiles, kerbs, kerb_red)
    for array in arrays:
        array.setflags(write=False)
    return ProceduralTrack(*arrays, attempts=attempts)


def _quads(
    points: np.ndarray,
    normals: np.ndarray,
    rows: np.ndarray,
    inner: float | np.ndarray,
    outer: float | np.ndarray,
) -> np.ndarray:
    """Quads (len(rows), 4, 2) between each point i in ``rows`` and point i-1 (cyclic) [u].

    Vertices: point i + inner, point i + outer, point i-1 + outer, point i-1 + inner,
    each offset along that point's normal by the given distance [u] (one per row, or one
    for all).
    """
    inner, outer = _column(inner), _column(outer)
    here, before = rows, rows - 1  # index -1 is the last point: the lap is a loop
    return np.stack(
        (
            points[here] + inner * normals[here],
            points[here] + outer * normals[here],
            points[before] + outer * normals[before],
            points[before] + inner * normals[before],
        ),
        axis=1,
    )


def _column(value: float | np.ndarray) -> float | np.ndarray:
    """A per-row array as a column (it scales the rows of an (N, 2) array); a number as is."""
    return value[:, None] if isinstance(value, np.ndarray) else value


def _cyclic_windows(length: int, offsets: range) -> np.ndarray:
    """(len(offsets), length) indices: row k holds (i + offsets[k]) mod length for each i."""
    windows: np.ndarray = (np.arange(length) + np.array(offsets)[:, None]) % length
    return windows


def _kerbs(
    centerline: np.ndarray,
    headings: np.ndarray,
    normals: np.ndarray,
    params: ProceduralTrackParams,
) -> tuple[np.ndarray, np.ndarray]:
    """Kerb quads (K, 4, 2) [u] on the outer side of hard turns, and their red flags (K,)."""
    turns = headings - headings[np.arange(-1, len(headings) - 1)]  # [rad] into each point
    flagged = _spread_back(_hard_turns(turns, params), params.border_min_count)
    index = np.flatnonzero(flagged)
    side = np.sign(-turns[index])  # +1 or -1: the outer side of the turn along the normal
    kerbs = _quads(
        centerline,
        normals,
        index,
        side * params.half_width,
        side * (params.half_width + params.border),
    )
    return kerbs, index % 2 == 1


def _hard_turns(turns: np.ndarray, params: ProceduralTrackParams) -> np.ndarray:
    """Points whose last ``border_min_count`` turns are all sharp and all one way.

    Indices wrap: the first points look back across the seam to the lap's
    last points, as CarRacing does (headings there differ by well under a turn).
    """
    count = params.border_min_count
    window = turns[_cyclic_windows(len(turns), range(0, -count, -1))]  # row k: turn k back
    sharp = np.all(np.abs(window) > params.turn_rate * _KERB_TURN_FRACTION, axis=0)
    one_way = np.abs(np.sign(window).sum(axis=0)) == count
    hard: np.ndarray = sharp & one_way
    return hard


def _spread_back(flags: np.ndarray, count: int) -> np.ndarray:
    """Also flag the ``count - 1`` points before each flagged point, cyclically.

    CarRacing spreads in place while walking forward, so flags on the first
    points wrap to the end of the lap and spread once more from there.
    """
    spread = flags.copy()
    for k in range(1, count):
        spread[-k % len(spread)] |= flags[: count - k].any()  # wraps on laps shorter than count
    spread_back: np.ndarray = spread[_cyclic_windows(len(spread), range(count))].any(axis=0)
    return spread_back
