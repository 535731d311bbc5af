"""Episodes on tracks in metres (centreline CSV, cone map, ROS map): tiles, laps, collisions.

The rules are CarRacing's on a road read from a file: progress tiles along the
centreline pay ``tile_progress`` per lap and close a lap; the cross-track error is the
distance to the centreline. Cones are knocked over once each (a reward term, and the
end of the episode if the track says so); walls stop the car where it stood before the
step (a reward term per step, and optionally the end).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from tinyrace.cars.kinematic_throttle import KinematicThrottleCar
from tinyrace.cars.registry import CarModel
from tinyrace.config import CameraConfig, EnvConfig
from tinyrace.episodes.image import footprint_corners
from tinyrace.episodes.procedural import CameraViews
from tinyrace.render.metric_ground import MetricOverview, paint_ground
from tinyrace.sensors.birdseye_camera import RoiCamera
from tinyrace.sensors.texture import GroundTexture, transform_points
from tinyrace.tracks.base import TrackDraw
from tinyrace.tracks.metric import MetricSource, MetricTrack
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import World

DEFAULT_VIEW = (96, 96)  # [px] (h, w) the observation when no camera is configured
VIEW_SPAN = 14.0  # [wheelbases] the default view's side
NO_REFERENCE = "no reference line: this ros_map track has no waypoints (track.waypoints)"
CAR_COLOR = (204, 0, 0)  # RGB, the car drawn into the default view


@dataclass(eq=False)
class PreparedMetricTrack:
    """One track and its ground texture, made once per env; the overview when first drawn."""

    track: MetricTrack
    texture: GroundTexture
    overview: MetricOverview | None = None


class MetricEpisode:
    """One reset on a track in metres: a world with the track's cones and walls, one car."""

    def __init__(
        self,
        config: EnvConfig,
        prepared: PreparedMetricTrack,
        draw: TrackDraw,
        car_model: CarModel,
    ):
        self.config = config
        self.prepared = prepared
        self.layout = draw.track  # the generic view (tinyrace.tracks.base.Track)
        self.track: MetricTrack = draw.track.detail
        self.track_index = draw.track_index
        self.track_config = config.tracks[draw.track_index]
        self.lap_percent: float = getattr(self.track_config, "lap_complete_percent", 0.95)
        self.world = World()
        if len(self.track.tiles) and config.car.model == "dynamic":
            self.world.add_tiles(self.track.tiles)  # grip: wheels on the road
        self.world.add_cones(self.track.cones[:, :2], self.track.cone_radii)
        self.world.add_walls(self.track.walls)
        self.car = car_model.build(self.world.space, draw.spawn, config.car, draw.track)
        tiles = len(self.track.tiles)
        self.visited = np.zeros(tiles, bool)
        self.visited_count = 0
        self.knocked: set[int] = set()
        self.nearest = -1  # centreline index near the car (-1: search all)
        self.tile = -1  # the tile under the car at the last step (-1: none yet)
        self.cte: float | None = None
        self.on_road = True
        self.walls_hit = 0
        self.view = self._default_view()  # the observation when no camera is configured

    def _default_view(self) -> RoiCamera:
        span = VIEW_SPAN * self.car.footprint[0]  # [m]
        view = CameraConfig(
            id="view", resolution=DEFAULT_VIEW, roi=(span, span), position=(-span / 4, 0.0)
        )
        return RoiCamera(view, self.prepared.texture, y_down=False)

    # -- physics and facts -------------------------------------------------------------------
    def start(self, dt: float) -> StepFacts:
        """The reset's look at the spawn: sensors only, the car does not move."""
        self.world.step(dt)
        return self._progress(StepFacts(tiles_total=len(self.visited)))

    def step(self, dt: float) -> StepFacts:
        body = self.car.body
        x, y = body.position
        before = ((float(x), float(y)), float(body.angle))
        on_road = [bool(tiles) for tiles in self.world.contacts.wheel_tiles]
        if self.track.occupancy is not None or not len(self.track.tiles):
            on_road = [True] * 4  # a map's free space grips everywhere
        self.car.apply_forces(dt, on_road)
        contacts = self.world.step(dt)
        facts = StepFacts(tiles_total=len(self.visited))
        if contacts.walls:
            facts.wall_hit = True
            self.walls_hit += 1
            self._crash(before)
            facts.collision_ends = getattr(self.track_config, "wall_hit_ends_episode", False)
        new_cones = contacts.cones - self.knocked
        if new_cones:
            self.knocked |= new_cones
            facts.cones_hit = len(new_cones)
            facts.collision_ends |= getattr(self.track_config, "cone_hit_ends_episode", False)
        x, y, _ = self.car.pose
        x0, y0, x1, y1 = self.track.bounds
        facts.out_of_bounds = not (x0 <= x <= x1 and y0 <= y <= y1)
        wheels = self.world.contacts.wheel_tiles
        if self.config.car.model == "dynamic" and len(self.track.tiles):
            facts.wheels_on_grass = sum(not tiles for tiles in wheels)
        return self._progress(facts)

    def _crash(self, before: tuple[tuple[float, float], float]) -> None:
        """Against a wall: back to where the car stood before the step, at a standstill."""
        body = self.car.body
        body.position, body.angle = before
        body.velocity, body.angular_velocity = (0.0, 0.0), 0.0
        if isinstance(self.car, KinematicThrottleCar):
            self.car.stop()
        for wheel in getattr(self.car, "wheels", ()):
            wheel.omega = 0.0

    def _progress(self, facts: StepFacts) -> StepFacts:
        """Tiles passed since the last step (along the centreline), the lap rule, the cte."""
        circuit = self.track.circuit
        if circuit is None:
            return facts
        x, y = self.car.rear_axle
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

    def info(self) -> dict[str, Any]:
        x, y, heading = self.car.pose
        info = {
            "pose": (x, y, heading),
            "speed": self.car.speed,  # [m/s]
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

    # -- pictures ----------------------------------------------------------------------------
    def observe(self, t: float, score: float) -> np.ndarray:
        """The observation without cameras: a 96x96 top view of the road ahead, with the car."""
        front, heading = self.car.front_axle, self.car.pose[2]
        image = self.view.render(front, heading)
        matrix = self.view.matrix(front, heading)
        corners = transform_points(matrix, footprint_corners(self.car))
        cv2.fillConvexPoly(
            image, np.round(corners * 16).astype(np.int32), CAR_COLOR, cv2.LINE_AA, 4
        )
        return image

    def frame(self, mode: str, t: float, score: float, cameras: CameraViews = ()) -> np.ndarray:
        """state_pixels: the first camera or the default view; rgb_array and human: the
        overview. ``cameras``: each camera's (image, window corners) now."""
        images = [image for image, _ in cameras] or [self.observe(t, score)]
        if mode == "state_pixels":
            return images[0]
        windows = [corners for _, corners in cameras]
        if self.prepared.overview is None:
            self.prepared.overview = MetricOverview(self.track, self.prepared.texture)
        return self.prepared.overview.render(footprint_corners(self.car), windows, images)

    def ground_texture(self) -> GroundTexture:
        """The track picture the cameras see."""
        return self.prepared.texture


def _between(previous: int, current: int, n: int) -> list[int]:
    """Tiles from ``previous`` to ``current`` going forward (a short way), ``current`` last."""
    forward = (current - previous) % n
    if forward <= n // 4:
        return [(previous + k) % n for k in range(1, forward + 1)] or [current]
    return [current]  # backwards or a jump: only the tile under the car


class MetricCourse:
    """What lasts across resets: the ground texture of every track of the source."""

    def __init__(self, config: EnvConfig, source: MetricSource, car_model: CarModel):
        self.config = config
        self.source = source
        self.car_model = car_model
        self.prepared = []
        for layout, track_config in zip(source.tracks, config.tracks, strict=True):
            texture = paint_ground(layout.detail, getattr(track_config, "pixels_per_meter", 20.0))
            self.prepared.append(PreparedMetricTrack(layout.detail, texture))

    @property
    def tracks(self) -> list[MetricTrack]:
        return [p.track for p in self.prepared]

    def new_episode(self, draw: TrackDraw) -> MetricEpisode:
        prepared = self.prepared[draw.track_index]
        return MetricEpisode(self.config, prepared, draw, self.car_model)
