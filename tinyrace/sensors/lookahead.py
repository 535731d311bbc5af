"""Lookahead core: the next points of a reference line in the car's frame, with curvature.

The line is resampled once per track on a fine grid of arc length (``ReferenceLine``) with
its curvature at every grid point (from the circle through the points one ``spacing``
before and after, so that a polyline's corners do not spike it). Each observation finds the
car's arc length near the previous one (a window of the grid, not the whole line) and reads
the K points ``spacing`` apart ahead of it off the grid (the spacing is rounded to a whole
number of grid steps: within 1/(16 x grid points) of the one asked for).

Car frame: x ahead, y to the left [track units]; curvature [1/track unit] is positive for a
left turn, on y-up and y-down tracks alike.

Speed: at K = 10 points each numpy call costs more than its arithmetic, so an observation
makes few: the grid is kept padded (windows and the points ahead are slices, never index
arithmetic) and as complex numbers (``PlanePoints``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from gymnasium import spaces

from tinyrace.config.bounds import MAX_LOOKAHEAD_GRID
from tinyrace.config.sensors import LookaheadConfig
from tinyrace.errors import ConfigError, Problem
from tinyrace.sensors.base import SensorContext, TopDown
from tinyrace.sensors.machinery.common import PerTrack, PlanePoints, Unsupported
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

FINE = 8  # grid points per spacing
MAX_GRID = MAX_LOOKAHEAD_GRID  # grid points of a reference line (its length / spacing x FINE)
WINDOW = 16  # grid points searched either side of the previous match (2 spacings)
REACH = 4  # the observation's x and y saturate at this many times K spacings
PAIRS = np.dtype((np.float64, (2,)))  # a complex array viewed as (N, 2) real rows


class ReferenceLine:
    """A line resampled on a grid of arc length, ``FINE`` grid steps per lookahead spacing;
    ``table`` rows: x, y [track units] and curvature [1/track unit, + left turn]."""

    def __init__(self, table: np.ndarray, step: float, closed: bool):
        self.table = table  # (M, 3)
        self.points = table[:, :2]
        self.step = step  # [track units] between grid points
        self.closed = closed
        self._pad(WINDOW)

    @classmethod
    def build(cls, line: np.ndarray, closed: bool, spacing: float, y_down: bool) -> ReferenceLine:
        """Resample ``line`` (N, 2) for lookahead points about ``spacing`` [track units]
        apart: the spacing is rounded so that the line holds a whole number of grid steps."""
        line = np.asarray(line, np.float64)
        if closed:
            line = np.vstack([line, line[:1]])
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
        if not s[-1] / (spacing / FINE) <= MAX_GRID:
            raise ConfigError(
                Problem(
                    "<sensors>",
                    "lookahead spacing",
                    spacing,
                    f"expected a spacing >= {s[-1] * FINE / MAX_GRID:.3g} track units on this "
                    f"track (a line {s[-1]:.4g} long; at most {MAX_GRID // FINE:,} points of "
                    "lookahead per lap)",
                )
            )
        intervals = max(round(s[-1] / (spacing / FINE)), 2)
        count = intervals if closed else intervals + 1
        grid = np.linspace(0.0, s[-1], count, endpoint=not closed)
        points = np.stack([np.interp(grid, s, line[:, 0]), np.interp(grid, s, line[:, 1])], 1)
        curvature = _menger(points, FINE, closed) * (-1.0 if y_down else 1.0)
        return cls(np.column_stack([points, curvature]), s[-1] / intervals, closed)

    @property
    def spacing(self) -> float:
        """[track units] between lookahead points."""
        return FINE * self.step

    def _pad(self, after: int) -> None:
        """Keep the grid with WINDOW rows before it and ``after`` rows after it (wrapped round
        a closed line, repeats of the end rows of an open one), so that windows and the points
        ahead are slices: grid point i is element i + WINDOW."""
        m = len(self.table)
        rows = np.arange(-WINDOW, m + after)
        padded = self.table[rows % m if self.closed else np.clip(rows, 0, m - 1)]
        self._plane = PlanePoints.of(padded[:, :2])
        self._curvature: np.ndarray = padded[:, 2].copy()
        # float32 rows whose curvature column observations copy (x and y are overwritten)
        self._rows32 = padded.astype(np.float32)
        self._point_list: list[complex] = self._plane.points.tolist()  # fast to index one

    def distance(self, index: int, x: float, y: float) -> float:
        """[track units] from (x, y) to grid point ``index``."""
        return abs(self._point_list[index + WINDOW] - complex(x, y))

    def nearest(self, x: float, y: float, near: int | None) -> int:
        """Index of the grid point nearest (x, y), searched around ``near`` when given (and
        along the whole line when the best of that window is at its edge)."""
        m = len(self.table)
        if near is not None:
            window = self._plane.points[near : near + 2 * WINDOW + 1]
            best = int(np.abs(window - complex(x, y)).argmin())
            if 0 < best < 2 * WINDOW:
                index = near + best - WINDOW
                return index % m if self.closed else min(max(index, 0), m - 1)
        grid = self._plane.points[WINDOW : WINDOW + m]
        return int(np.abs(grid - complex(x, y)).argmin())

    def follow(
        self, pose: tuple[float, float, float], y_down: bool, near: int | None, count: int
    ) -> tuple[int, np.ndarray]:
        """``nearest`` the pose's point and ``lookahead`` from there, sharing one subtraction
        (a y-down pose uses the mirrored points, which have the same distances) when the
        nearest point is inside the window around ``near``; else the two calls."""
        x, y, heading = pose
        m = len(self.table)
        if near is not None:
            if len(self._curvature) < m + 2 * WINDOW + FINE * count:
                self._pad(WINDOW + FINE * count)
            plane = self._plane
            source, origin = (
                (plane.mirrored, complex(x, -y)) if y_down else (plane.points, complex(x, y))
            )
            offsets = source[near : near + 2 * WINDOW + FINE * count] - origin
            best = int(np.abs(offsets[: 2 * WINDOW + 1]).argmin())
            index = near + best - WINDOW
            if 0 < best < 2 * WINDOW and 0 <= index < m:  # neither wrapped nor clipped
                c, s = math.cos(heading), math.sin(heading)
                turn = complex(c, s) if y_down else complex(c, -s)
                local = offsets[best + FINE : best + FINE * (count + 1) : FINE] * turn
                start = index + WINDOW + FINE
                out = self.rows32(slice(start, start + FINE * count, FINE))
                out[:, :2] = local.view(PAIRS)
                return index, out
        index = self.nearest(x, y, near)
        return index, lookahead(self, index, pose, y_down, count)

    def ahead(self, index: int, count: int) -> tuple[PlanePoints, slice]:
        """The padded points and the part of them 1, 2, ... ``count`` spacings after grid
        point ``index``; their curvatures are ``curvature(part)``."""
        if len(self._curvature) < len(self.table) + WINDOW + FINE * count:
            self._pad(max(WINDOW, FINE * count))
        start = index + WINDOW + FINE
        return self._plane, slice(start, start + FINE * count, FINE)

    def rows32(self, part: slice) -> np.ndarray:
        """A new float32 (count, 3) array holding the curvatures of a ``part`` of the
        padded points in its last column (see ``ahead``)."""
        rows: np.ndarray = self._rows32[part].copy()
        return rows

    def curvature(self, part: slice) -> np.ndarray:
        """[1/track unit] of a ``part`` of the padded points (see ``ahead``)."""
        values: np.ndarray = self._curvature[part]
        return values


def _menger(points: np.ndarray, offset: int, closed: bool) -> np.ndarray:
    """Signed curvature of the circle through each point and the points ``offset`` before
    and after it (+ counter-clockwise in the points' frame)."""
    index = np.arange(len(points))
    if closed:
        before = points[(index - offset) % len(points)]
        after = points[(index + offset) % len(points)]
    else:
        before = points[np.clip(index - offset, 0, len(points) - 1)]
        after = points[np.clip(index + offset, 0, len(points) - 1)]
    a, b = points - before, after - points
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    lengths = np.hypot(*a.T) * np.hypot(*b.T) * np.hypot(*(after - before).T)
    curvature: np.ndarray = np.divide(
        2 * cross, lengths, out=np.zeros(len(points)), where=lengths > 0
    )
    return curvature


def lookahead(
    line: ReferenceLine, index: int, pose: tuple[float, float, float], y_down: bool, count: int
) -> np.ndarray:
    """(count, 3) float32 rows x, y [track units, car frame: ahead, left] and curvature
    [1/track unit] of the points one, two, ... ``line.spacing`` ahead of grid point
    ``index`` (an open line stops at its end)."""
    plane, part = line.ahead(index, count)
    local = plane.seen_from(pose, y_down, part)  # ahead + i left
    out = line.rows32(part)  # curvature already in place
    out[:, :2] = local.view(PAIRS)
    return out


def order_points(
    pixels: np.ndarray, start: tuple[float, float, float], spacing: float
) -> tuple[np.ndarray, bool]:
    """An unordered set of line pixels (K, 2) as a polyline from the one nearest ``start``
    (x, y, heading), setting off along the heading; closed when its ends meet.

    The pixels are first merged into one point per ``spacing`` cell; then each next point is
    the nearest unused one ahead (greedy), within 3 cells.
    """
    cells = np.floor(np.asarray(pixels, np.float64) / spacing).astype(np.int64)
    _, inverse = np.unique(cells, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    sums = np.zeros((inverse.max() + 1, 2))
    np.add.at(sums, inverse, pixels)
    points = sums / np.bincount(inverse)[:, None]
    x, y, heading = start
    first = int(np.argmin(np.hypot(points[:, 0] - x, points[:, 1] - y)))
    direction = np.array([math.cos(heading), math.sin(heading)])
    order, used = [first], np.zeros(len(points), bool)
    used[first] = True
    while True:
        here = points[order[-1]]
        d = points - here
        distance = np.hypot(d[:, 0], d[:, 1])
        ahead = (d @ direction) > -0.25 * distance  # no turning back on the first pick
        candidates = ~used & (distance <= 3 * spacing) & (ahead if len(order) == 1 else True)
        if not candidates.any():
            break
        nxt = int(np.argmin(np.where(candidates, distance, np.inf)))
        order.append(nxt)
        used[nxt] = True
    line = points[order]
    closed = len(line) > 3 and np.hypot(*(line[-1] - line[0])) <= 3 * spacing
    return line, bool(closed)


class LookaheadSensor:
    """``type: lookahead``: (K, 3) float32 rows x, y [track units, car frame: ahead, left]
    and curvature [1/track unit, + left] of the reference line ahead of the front axle.
    Bounds: x and y within +-4 K spacings (saturating), curvature within +-16 / spacing."""

    def __init__(self, config: LookaheadConfig, spacing: float):
        self.config = config
        self.spacing = spacing  # [track units]
        # points saturate at REACH x K spacings per axis (a car that far off the line has no
        # use for them); curvature at that of a circle through three points one step apart
        reach = REACH * config.points * spacing  # [track units]
        high = np.tile(np.array([reach, reach, 2 * FINE / spacing], np.float32), (config.points, 1))
        self.space = spaces.Box(-high, high, dtype=np.float32)
        self._reach = float(high[0, 0])  # [track units] the bound of x and y, as float32
        self._lines: PerTrack[ReferenceLine] = PerTrack()
        self._line: ReferenceLine | None = None
        self._index: int | None = None
        self._curvature_fits = False  # every curvature of the line is within the bounds
        self._extent = math.inf  # [track units] of arc from the nearest to the last point

    @property
    def id(self) -> str:
        return self.config.id

    def describe(self) -> str:
        c = self.config
        return f"{c.points} points of the reference line ahead, {self.spacing:g} apart"

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        return None  # its observation is no picture from above

    def reset(self, track: Track) -> None:
        try:
            self._line = line = self._lines.get(track, self._build_line)
        except ConfigError as exc:  # name the sensor
            problem = exc.problems[0]
            where = f"sensors[id {self.config.id}].spacing"
            raise ConfigError(dataclasses.replace(problem, path=where)) from None
        self._index = None
        curvature = np.abs(line.table[:, 2].astype(np.float32)).max(initial=0.0)
        self._curvature_fits = bool(curvature <= self.space.high[0, 2])
        self._extent = self.config.points * line.spacing

    def _build_line(self, track: Track) -> ReferenceLine:
        if track.centerline is not None:
            return ReferenceLine.build(track.centerline, True, self.spacing, track.y_down)
        layer = next(layer for layer in track.layers if layer.role == "trajectory")
        assert layer.points is not None, "build() asks the image track to keep them"
        line, closed = order_points(layer.points, track.spawns[0], self.spacing / 2)
        return ReferenceLine.build(line, closed, self.spacing, track.y_down)

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> np.ndarray:
        car = snapshot.car
        x, y = car.front_axle
        line = self._line
        assert line is not None, "reset() before observe()"
        pose = (x, y, car.pose[2])
        index, rows = line.follow(pose, track.y_down, self._index, self.config.points)
        self._index = index
        if self._within_bounds(line, index, x, y):
            return rows  # clamping would change nothing
        np.minimum(rows, self.space.high, out=rows)  # np.clip's wrapper costs more than both
        clamped: np.ndarray = np.maximum(rows, self.space.low, out=rows)
        return clamped

    def _within_bounds(self, line: ReferenceLine, index: int, x: float, y: float) -> bool:
        """Whether every row of an observation from (x, y) at grid point ``index`` is surely
        within the bounds: the points ahead lie at most K spacings of arc (so of chord) from
        that grid point, with a margin for rounding."""
        if not self._curvature_fits:
            return False
        extent = line.distance(index, x, y) + self._extent  # [track units]
        return extent * 1.001 + 1e-9 < self._reach


def build(config: LookaheadConfig, context: SensorContext) -> LookaheadSensor:
    """The lookahead sensor: needs a reference line (a procedural centreline, or an image
    track's trajectory colour with cross_track_error.use_cte)."""
    env = context.env
    for track in env.tracks:
        missing = track.reference_problem(env.reward_design)
        if missing is not None:
            raise Unsupported(f"{missing}: lookahead follows the reference line")
    spacing = config.spacing if config.spacing is not None else context.car.length
    return LookaheadSensor(config, spacing)
