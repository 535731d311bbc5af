"""What an experiment measures along the track's reference line where the env does not:
the distance to CarRacing's centreline (the env reports a cross-track error on image and
metric tracks only) and laps on image tracks (the env counts laps by progress tiles, and
image tracks have none)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

from tinyrace.drivers.centerline import route_of

WINDOW = (-5, 25)  # route points searched around the last nearest one (a track may pass close)


class RouteWatch:
    """Follows a car along a polyline: its distance to the line and its laps round it.

    ``points`` (N, 2) [track units] in driving order, point 0 at the start; ``closed``: the
    last point joins the first (only a closed line has laps).
    """

    def __init__(self, points: np.ndarray, closed: bool):
        self.points = np.asarray(points, float)
        self.closed = closed and len(self.points) > 2
        ends = np.roll(self.points, -1, axis=0) if self.closed else self.points[1:]
        self._starts = self.points if self.closed else self.points[:-1]
        self._edges = ends - self._starts
        self._nearest = -1  # unknown: search the whole line once
        self._progress = 0  # [route points] driven forward since the start, net
        self._start = 0  # [route points] where the car started, from point 0 (- behind it)

    def distance(self, x: float, y: float) -> float:
        """[track units] from (x, y) to the nearest point of the line."""
        if len(self._edges) == 0:
            return math.hypot(x - self.points[0, 0], y - self.points[0, 1])
        offsets = np.array([x, y]) - self._starts
        lengths = np.einsum("ij,ij->i", self._edges, self._edges)
        along = np.einsum("ij,ij->i", offsets, self._edges) / np.maximum(lengths, 1e-12)
        along = np.clip(along, 0.0, 1.0)  # the nearest point of each segment
        gaps = offsets - along[:, None] * self._edges
        return float(np.sqrt(np.einsum("ij,ij->i", gaps, gaps).min()))

    @property
    def along(self) -> int:
        """[route points] from point 0 (the start line) to the car, counted round the line
        since the start (negative behind it); as of the last ``laps``."""
        return self._start + self._progress

    def laps(self, x: float, y: float) -> int:
        """Laps finished once the car is at (x, y): whole rounds of net forward progress."""
        n = len(self.points)
        if not self.closed:
            return 0
        if self._nearest < 0:
            candidates = np.arange(n)
        else:
            candidates = np.arange(self._nearest + WINDOW[0], self._nearest + WINDOW[1]) % n
        offsets = self.points[candidates] - (x, y)
        nearest = int(candidates[np.argmin(np.einsum("ij,ij->i", offsets, offsets))])
        if self._nearest >= 0:
            self._progress += (nearest - self._nearest + n // 2) % n - n // 2
        else:
            self._start = (nearest + n // 2) % n - n // 2
        self._nearest = nearest
        return max(self._progress, 0) // n


def route_watch(env: gym.Env) -> RouteWatch | None:
    """The watch of the env's current track (after its reset); None without a line."""
    try:
        route = route_of(env)
    except ValueError:  # an image track without a trajectory colour, a ros_map without CSV
        return None
    return RouteWatch(route.points, route.closed)
