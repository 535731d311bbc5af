"""Episodes on tracks in metres (centreline CSV, cone map, ROS map): tiles, laps, collisions.

The rules are CarRacing's on a road read from a file: progress tiles along the
centreline pay ``tile_progress`` per lap and close a lap; the cross-track error is the
distance to the centreline. Cones are knocked over once each (a reward term, and the
end of the episode if the track says so); walls stop the car where it stood before the
step (a reward term per step, and optionally the end).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tinyrace.cars.registry import CarModel
from tinyrace.config import EnvConfig
from tinyrace.tracks.base import TrackDraw
from tinyrace.tracks.metric import MetricSource, MetricTrack
from tinyrace.world.facts import StepFacts
from tinyrace.world.snapshot import Snapshot
from tinyrace.world.world import World

NO_REFERENCE = "no reference line: this ros_map track has no waypoints (track.waypoints)"


class MetricEpisode:
    """One reset on a track in metres: a world with the track's cones and walls, one car."""

    def __init__(self, config: EnvConfig, draw: TrackDraw, car_model: CarModel):
        self.config = config
        self.layout = draw.track  # the generic view (tinyrace.tracks.base.Track)
        self.track: MetricTrack = draw.track.detail
        self.track_index = draw.track_index
        self.track_config = config.tracks[draw.track_index]
        self.lap_percent: float = getattr(self.track_config, "lap_complete_percent", 0.95)
        tiles = len(self.track.tiles)
        self.grip_tiles = tiles > 0 and car_model.wheels  # wheels feel the road
        self.world = World(grass_off_tiles=self.grip_tiles and self.track.occupancy is None)
        if self.grip_tiles:
            self.world.add_tiles(self.track.tiles)
        self.world.add_cones(self.track.cones[:, :2], self.track.cone_radii)
        self.world.add_walls(self.track.walls)
        self.world.add_car(car_model.build(self.world.space, draw.spawn, config.car, draw.track))
        self.visited = np.zeros(tiles, bool)
        self.visited_count = 0
        self.visit_order: list[int] = []  # tiles in the order first visited
        self.knocked: set[int] = set()
        self.nearest = -1  # centreline index near the car (-1: search all)
        self.tile = -1  # the tile under the car at the last step (-1: none yet)
        self.cte: float | None = None
        self.on_road = True
        self.walls_hit = 0

    # -- rules ---------------------------------------------------------------------------------
    def start(self, dt: float) -> StepFacts:
        """The reset's look at the spawn: sensors only, the car does not move."""
        self.world.look(dt)
        return self._progress(StepFacts(tiles_total=len(self.visited)))

    def step(self, dt: float, forces_applied: bool = False) -> StepFacts:
        """The world's step (a wall stops the car there); cones, bounds, tiles and laps."""
        contacts = self.world.step(dt, forces_applied=forces_applied)
        facts = StepFacts(tiles_total=len(self.visited))
        if contacts.crashed:
            facts.wall_hit = True
            self.walls_hit += 1
            facts.collision_ends = getattr(self.track_config, "wall_hit_ends_episode", False)
        new_cones = contacts.cones - self.knocked
        if new_cones:
            self.knocked |= new_cones
            facts.cones_hit = len(new_cones)
            facts.collision_ends |= getattr(self.track_config, "cone_hit_ends_episode", False)
        x, y, _ = self.world.states()[0].pose
        x0, y0, x1, y1 = self.track.bounds
        facts.out_of_bounds = not (x0 <= x <= x1 and y0 <= y <= y1)
        if self.grip_tiles:
            facts.wheels_on_grass = sum(not tiles for tiles in contacts.wheel_tiles)
        return self._progress(facts)

    def _progress(self, facts: StepFacts) -> StepFacts:
        """Tiles passed since the last step (along the centreline), the lap rule, the cte."""
        circuit = self.track.circuit
        if circuit is None:
            return facts
        x, y = self.world.states()[0].rear_axle
        previous, (index, lateral) = self.tile, self._locate(x, y)
        self.tile = index
        self.cte = abs(lateral)
        facts.cte = self.cte
        right, left = circuit.widths[index]
        self.on_road = bool(-right <= lateral <= left)
        if not self.on_road:
            return facts
        n = len(self.visited)
        passed = [index] if previous < 0 else _between(previous, index, n)
        for tile in passed:
            if not self.visited[tile]:
                self.visited[tile] = True
                self.visited_count += 1
                self.visit_order.append(tile)
                facts.new_tiles += 1
            if tile == 0 and self.visited_count / n > self.lap_percent:
                facts.lap_finished = True
        if self.visited_count == n:
            facts.lap_finished = True
        return facts

    def _locate(self, x: float, y: float) -> tuple[int, float]:
        """(tile index, signed lateral offset [m], + left) of a point, searched near the last."""
        circuit = self.track.circuit
        assert circuit is not None  # only tracks with a reference line have tiles
        points = circuit.centerline
        n = len(points)
        if self.nearest < 0:
            candidates = np.arange(n)
        else:
            reach = max(int(60.0 / circuit.spacing), 8)  # [points] ~ 60 m either way
            candidates = np.arange(self.nearest - reach, self.nearest + reach) % n
        offsets = points[candidates] - (x, y)
        nearest = int(candidates[np.argmin(np.einsum("ij,ij->i", offsets, offsets))])
        heading = circuit.headings[nearest]
        dx, dy = x - points[nearest, 0], y - points[nearest, 1]
        along = dx * math.cos(heading) + dy * math.sin(heading)
        lateral = -dx * math.sin(heading) + dy * math.cos(heading)
        tile = nearest if along >= 0 else (nearest - 1) % n
        self.nearest = nearest
        return tile, lateral

    def info(self, snapshot: Snapshot) -> dict[str, Any]:
        car = snapshot.car
        info = {
            "pose": car.pose,
            "speed": car.speed,  # [m/s]
            "track": self.track_index,
            "unit": "m",
            "tiles_visited": self.visited_count,
            "tiles_total": len(self.visited),
            "on_road": self.on_road,
            "cones_hit": len(self.knocked),
            "walls_hit": self.walls_hit,
        }
        if self.track.circuit is None:
            info["cte_unavailable"] = NO_REFERENCE
        elif self.cte is not None:
            info["cte"] = self.cte  # [m]
        return info


def _between(previous: int, current: int, n: int) -> list[int]:
    """Tiles from ``previous`` to ``current`` going forward (a short way), ``current`` last."""
    forward = (current - previous) % n
    if forward <= n // 4:
        return [(previous + k) % n for k in range(1, forward + 1)] or [current]
    return [current]  # backwards or a jump: only the tile under the car


class MetricCourse:
    """What lasts across resets: the source (its tracks, loaded once)."""

    def __init__(self, config: EnvConfig, source: MetricSource, car_model: CarModel):
        self.config = config
        self.source = source
        self.car_model = car_model

    @property
    def tracks(self) -> list[MetricTrack]:
        return [layout.detail for layout in self.source.tracks]

    def new_episode(self, draw: TrackDraw) -> MetricEpisode:
        return MetricEpisode(self.config, draw, self.car_model)
