"""A 2D lidar in the plane of the track: ranges to walls and cones, and what each beam hit.

Like F1TENTH's simulator, the obstacles of a track (its walls and cones) are drawn once
into a raster whose Euclidean distance transform gives, for any point, the distance to
the nearest obstacle; each beam marches by that distance until it is within ``epsilon``
of an obstacle or past ``max_range``. The class of each hit comes from the nearest
obstacle's label: 0 nothing, 1 wall, 2 + k a cone of class k (``tracks.cone_map.CLASSES``).
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np
from gymnasium import spaces

from tinyrace.config import LidarConfig
from tinyrace.sensors.base import SensorContext
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

MAX_CELLS = 8192  # [cells] the raster's longest side; coarser cells beyond it
WALL_CLASS = 1  # beam class of a wall; a cone of class k is WALL_CLASS + k
NO_HIT = 0


class ObstacleField:
    """A track's walls and cones as a distance raster [track units] and a class raster."""

    def __init__(self, track: Track, resolution: float):
        x0, y0, x1, y1 = track.bounds
        self.cell = max(resolution, (x1 - x0) / MAX_CELLS, (y1 - y0) / MAX_CELLS)
        self.origin = (x0, y0)
        width = max(math.ceil((x1 - x0) / self.cell), 1)
        height = max(math.ceil((y1 - y0) / self.cell), 1)
        classes = np.zeros((height, width), np.uint8)
        for bx0, by0, bx1, by1 in track.walls.tolist():
            (c0, r0), (c1, r1) = self.cells(np.array([[bx0, by0], [bx1, by1]]))
            cv2.rectangle(classes, (c0, r0), (c1, r1), WALL_CLASS, -1)
        for x, y, kind in track.cones.tolist():
            ((c, r),) = self.cells(np.array([[x, y]]))
            radius = max(round(0.115 / self.cell), 0)  # [cells] a cone's base
            cv2.circle(classes, (int(c), int(r)), radius, WALL_CLASS + int(kind), -1)
        free = (classes == NO_HIT).astype(np.uint8)
        self.distance = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * self.cell
        self.classes = cv2.dilate(classes, np.ones((5, 5), np.uint8))  # the class near a hit
        self.empty = not (track.walls.size or track.cones.size)

    def cells(self, points: np.ndarray) -> np.ndarray:
        """(K, 2) int (col, row) of world points (row 0 at the lowest y)."""
        return np.floor((points - self.origin) / self.cell).astype(int)


class Lidar:
    """The ``lidar`` sensor: ``beams`` ranges over ``fov`` centred ahead, index 0 rightmost."""

    def __init__(self, config: LidarConfig):
        self.config = config
        self.space = spaces.Dict(
            {
                "ranges": spaces.Box(0.0, config.max_range, (config.beams,), np.float32),
                "classes": spaces.Box(0, 255, (config.beams,), np.uint8),
            }
        )
        half = math.radians(config.fov) / 2
        self.offsets = np.linspace(-half, half, config.beams)  # [rad] + left of the heading
        self._fields: dict[int, ObstacleField] = {}
        self._field: ObstacleField | None = None

    @property
    def id(self) -> str:
        return self.config.id

    def reset(self, track: Track) -> None:
        key = id(track)
        if key not in self._fields:
            self._fields = {key: ObstacleField(track, self.config.resolution)}
        self._field = self._fields[key]

    def observe(
        self, snapshot: Snapshot, track: Track, rng: np.random.Generator
    ) -> dict[str, np.ndarray]:
        if self._field is None:
            self.reset(track)
        x, y, heading = snapshot.car.pose
        angles = heading - self.offsets if track.y_down else heading + self.offsets
        ranges, classes = self.cast((x, y), angles)
        return {"ranges": ranges.astype(np.float32), "classes": classes}

    def cast(self, origin: tuple[float, float], angles: np.ndarray) -> tuple[np.ndarray, Any]:
        """Ranges [track units] and hit classes of beams from ``origin`` along ``angles``.

        Only the beams still marching are updated each round (most stop within a few).
        """
        field, limit = self._field, self.config.max_range
        assert field is not None, "reset() prepares the track's field"
        count = len(angles)
        if field.empty:
            return np.full(count, limit), np.zeros(count, np.uint8)
        height, width = field.distance.shape
        flat = field.distance.ravel()
        ox = (origin[0] - field.origin[0]) / field.cell  # [cells]
        oy = (origin[1] - field.origin[1]) / field.cell
        dx, dy = np.cos(angles) / field.cell, np.sin(angles) / field.cell  # [cells per unit]
        t = np.zeros(count)
        live = np.arange(count)
        for _ in range(self.config.max_steps):
            cols = np.floor(ox + t[live] * dx[live]).astype(np.int64)
            rows = np.floor(oy + t[live] * dy[live]).astype(np.int64)
            inside = (cols >= 0) & (cols < width) & (rows >= 0) & (rows < height)
            step = np.full(len(live), limit)
            step[inside] = flat[rows[inside] * width + cols[inside]]
            t[live] += step
            keep = (step > field.cell) & (t[live] < limit)
            live = live[keep]
            if not len(live):
                break
        hit = t < limit
        cols = np.floor(ox + t * dx).astype(np.int64)
        rows = np.floor(oy + t * dy).astype(np.int64)
        classes = np.zeros(count, np.uint8)
        ok = hit & (cols >= 0) & (cols < width) & (rows >= 0) & (rows < height)
        classes[ok] = field.classes[rows[ok], cols[ok]]
        return np.minimum(t, limit), classes

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_fields": {}, "_field": None}  # rebuilt on the next reset


def build(entry: LidarConfig, context: SensorContext) -> Lidar:
    """A ``lidar`` sensor from its ``sensors:`` entry."""
    return Lidar(entry)
