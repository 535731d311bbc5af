"""Opponents: the nearest other cars of a race, in the car's frame, as one float32 array.

The car frame is the cones' and the lookahead's: origin at the middle of the car's front
axle, x ahead, y to the left [track units]; angles + to the left on y-up and y-down
(picture) tracks alike. Each row is one other car, nearest first (by the distance from
the origin to the middle of its footprint, between its axles):

| column | unit | meaning |
|---|---|---|
| present | 1 or 0 | 1: a car; 0: padding (the row's other columns are 0 too) |
| x, y | track units | the middle of its footprint |
| vx, vy | track units/s | its velocity less the car's own, along x and y (no frame rotation term) |
| heading | rad | its heading less the car's own, wrapped to [-pi, pi) |

At most ``count`` rows are cars; cars farther than ``max_range`` are left out, and so are
all when the car races alone (every row padding), and cars gone from the track (they
finished the race: ``Snapshot.gone``; the lidar meets them no more either). Values are
clamped to the space: x and y to +-max_range, vx and vy to +-2 top speeds.
"""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from tinyrace.config.sensors import OpponentsConfig
from tinyrace.sensors.base import SensorContext, TopDown
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

COLUMNS = ("present", "x", "y", "vx", "vy", "heading")


def relative_rows(snapshot: Snapshot, y_down: bool) -> np.ndarray:
    """(N - 1, 6) float64 rows of ``COLUMNS`` for every car of ``snapshot`` but the first,
    seen from the first, in snapshot order (unsorted, unfiltered)."""
    car, others = snapshot.car, snapshot.cars[1:]
    heading = car.pose[2]
    fx, fy = math.cos(heading), math.sin(heading)
    lx, ly = (fy, -fx) if y_down else (-fy, fx)  # the car's left
    ox, oy = car.front_axle
    vx, vy = car.velocity
    rows = np.empty((len(others), len(COLUMNS)))
    for k, other in enumerate(others):
        length = other.footprint[0]
        turn = other.pose[2]
        cx = other.rear_axle[0] + length / 2 * math.cos(turn) - ox
        cy = other.rear_axle[1] + length / 2 * math.sin(turn) - oy
        dvx, dvy = other.velocity[0] - vx, other.velocity[1] - vy
        difference = (turn - heading + math.pi) % (2 * math.pi) - math.pi
        rows[k] = (
            1.0,
            cx * fx + cy * fy,
            cx * lx + cy * ly,
            dvx * fx + dvy * fy,
            dvx * lx + dvy * ly,
            -difference if y_down else difference,
        )
    return rows


class OpponentsSensor:
    """``type: opponents``: the nearest ``count`` other cars (see the module's table)."""

    def __init__(self, config: OpponentsConfig, max_range: float, top_speed: float, y_down: bool):
        self.config = config
        self.max_range = max_range  # [track units]
        self.y_down = y_down
        speed = 2 * top_speed  # [track units/s] two cars head on
        high = np.array([1.0, max_range, max_range, speed, speed, math.pi], np.float32)
        low = -high
        low[0] = 0.0
        shape = (config.count, len(COLUMNS))
        self.space = spaces.Box(
            np.broadcast_to(low, shape), np.broadcast_to(high, shape), dtype=np.float32
        )

    @property
    def id(self) -> str:
        return self.config.id

    def describe(self) -> str:
        return f"the {self.config.count} nearest other cars within {self.max_range:g}"

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        return None  # its observation is no picture from above

    def reset(self, track: Track) -> None:
        self.y_down = track.y_down

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> np.ndarray:
        out = np.zeros(self.space.shape, np.float32)
        if len(snapshot.cars) < 2:
            return out
        rows = relative_rows(snapshot, self.y_down)
        distance = np.hypot(rows[:, 1], rows[:, 2])
        if snapshot.gone:  # finished cars left the track
            distance[[k - 1 for k in snapshot.gone if k]] = np.inf
        order = np.argsort(distance, kind="stable")
        near = order[distance[order] <= self.max_range][: self.config.count]
        found = np.clip(rows[near], self.space.low[0], self.space.high[0])
        out[: len(found)] = found + 0.0  # no -0.0
        return out


def build(config: OpponentsConfig, context: SensorContext) -> OpponentsSensor:
    """The opponents sensor of ``config``: range 10 car lengths unless given."""
    car = context.car
    max_range = config.max_range if config.max_range is not None else 10 * car.length
    return OpponentsSensor(config, max_range, car.top_speed, y_down=context.env.facts.y_down)
