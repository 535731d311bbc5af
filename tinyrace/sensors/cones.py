"""A cone detector: the nearest cones around the car, in the car's frame, by class.

What a Formula Student perception stack hands to planning: for each of the ``count``
nearest cones within ``max_range`` (and the field of view), its position ahead of and to
the left of the car's rear axle [track units], its distance and its class id (1 blue,
2 yellow, 3 orange, 4 big orange, 5 unknown; ``tracks.cone_map.CLASSES``). Rows are
sorted by distance; rows without a cone are all zero (class 0).
"""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from tinyrace.config import ConeSensorConfig
from tinyrace.sensors.base import SensorContext
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

COLUMNS = ("ahead", "left", "distance", "class")


class ConeDetector:
    """The ``cones`` sensor: a (count, 4) float32 array, one row per detected cone."""

    def __init__(self, config: ConeSensorConfig):
        self.config = config
        bound = np.float32(config.max_range)
        low = np.array([-bound, -bound, 0, 0], np.float32)
        high = np.array([bound, bound, bound, 255], np.float32)
        self.space = spaces.Box(
            np.tile(low, (config.count, 1)), np.tile(high, (config.count, 1)), dtype=np.float32
        )

    @property
    def id(self) -> str:
        return self.config.id

    def reset(self, track: Track) -> None:
        """Nothing to prepare: cones are read from the track each time."""

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> np.ndarray:
        rows = np.zeros((self.config.count, len(COLUMNS)), np.float32)
        if not len(track.cones):
            return rows
        x, y, heading = snapshot.car.pose
        offsets = track.cones[:, :2] - (x, y)
        c, s = math.cos(heading), math.sin(heading)
        ahead = offsets[:, 0] * c + offsets[:, 1] * s
        left = -offsets[:, 0] * s + offsets[:, 1] * c
        if track.y_down:  # y down: the left of the heading is -y in the car frame
            left = -left
        distance = np.hypot(ahead, left)
        bearing = np.degrees(np.abs(np.arctan2(left, ahead)))
        seen = (distance <= self.config.max_range) & (bearing <= self.config.fov / 2)
        order = np.flatnonzero(seen)[np.argsort(distance[seen], kind="stable")][: self.config.count]
        found = np.column_stack((ahead, left, distance, track.cones[:, 2]))[order]
        rows[: len(found)] = found
        return rows


def build(entry: ConeSensorConfig, context: SensorContext) -> ConeDetector:
    """A ``cones`` sensor from its ``sensors:`` entry."""
    return ConeDetector(entry)
