"""Episodes on image tracks: obstacle colours under the footprint, distance to a trajectory."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from tinyrace.cars.base import Car
from tinyrace.cars.registry import CarModel
from tinyrace.config import EnvConfig
from tinyrace.episodes.procedural import CameraViews
from tinyrace.render.overview import Overview
from tinyrace.render.texture import GroundTexture
from tinyrace.tracks.base import TrackDraw
from tinyrace.tracks.image import ImageSource, ImageTrack, touched_obstacles
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import World

_ALL_ROAD = (True, True, True, True)  # image tracks have no grass: full grip everywhere


def footprint_corners(car: Car) -> np.ndarray:
    """(4, 2) corners of the car's footprint: track_width wide, rear axle to front axle."""
    x, y = car.rear_axle
    heading = car.pose[2]
    length, width = car.footprint
    fx, fy = math.cos(heading), math.sin(heading)
    rx, ry = -fy * width / 2, fx * width / 2  # half the width to the right (y down)
    return np.array(
        [
            (x - rx, y - ry),
            (x + rx, y + ry),
            (x + rx + length * fx, y + ry + length * fy),
            (x - rx + length * fx, y - ry + length * fy),
        ]
    )


@dataclass(eq=False)
class PreparedTrack:
    """One track, prepared once per env: its data, ground texture, pymunk world (obstacle
    sensors) and, when first drawn, its overview."""

    track: ImageTrack
    texture: GroundTexture
    world: World
    overview: Overview | None = None


class ImageEpisode:
    """One reset on an image track: the chosen track and spawn, a car in its world."""

    def __init__(
        self, config: EnvConfig, prepared: PreparedTrack, draw: TrackDraw, car_model: CarModel
    ):
        self.config = config
        self.prepared = prepared
        self.layout = draw.track  # the generic view (tinyrace.tracks.base.Track)
        self.track: ImageTrack = draw.track.detail
        self.track_index, self.spawn_index = draw.track_index, draw.spawn_index
        self.world = prepared.world
        self.world.remove_cars()  # the last episode's car; the obstacle sensors stay
        self.car = car_model.build(self.world.space, draw.spawn, config.car, draw.track)
        self.obstacles_hit: list[int] = []
        self.cte: float | None = None

    def start(self, dt: float) -> StepFacts:
        """The reset's look at the spawn: tinycarlo's reset neither moves the car nor rewards
        anything, so the car stays put (pymunk still reports its contacts) and the facts
        are for info only."""
        self._sense(dt)
        return StepFacts()

    def step(self, dt: float) -> StepFacts:
        """Drive ``dt`` seconds and report what the sensors saw."""
        self.car.apply_forces(dt, self.wheels_on_road())
        return self.advance(dt)

    def wheels_on_road(self) -> tuple[bool, ...]:
        """An image track has no grass: every wheel grips as on road."""
        return _ALL_ROAD

    def advance(self, dt: float) -> StepFacts:
        """The world's step once the car's forces are applied; what the sensors saw."""
        return self._sense(dt)

    def _sense(self, dt: float) -> StepFacts:
        contacts = self.world.step(dt)
        facts = StepFacts()
        if contacts.obstacle_cells:
            candidates = {int(self.track.cell_obstacles[i]) for i in contacts.obstacle_cells}
            facts.obstacles_hit = touched_obstacles(
                self.track, footprint_corners(self.car), candidates
            )
        x, y = self.car.rear_axle
        if self.track.trajectory is not None:
            facts.cte = self.track.trajectory.query(x, y)[0]
        width, height = self.track.size
        facts.out_of_bounds = not (-0.5 <= x < width - 0.5 and -0.5 <= y < height - 0.5)
        self.obstacles_hit, self.cte = facts.obstacles_hit, facts.cte
        return facts

    def info(self) -> dict[str, Any]:
        x, y, heading = self.car.pose
        colors = self.track.obstacle_colors
        info = {
            "pose": (x, y, heading),
            "speed": self.car.speed,
            "track": self.track_index,
            "spawn": self.spawn_index,
            "obstacles_hit": [repr(colors[i]) for i in self.obstacles_hit],  # "#rrggbb" each
        }
        if self.cte is not None:
            info["cte"] = self.cte  # [px]
        return info

    def frame(self, mode: str, t: float, score: float, cameras: CameraViews = ()) -> np.ndarray:
        """state_pixels: the first camera; rgb_array and human: the overview.

        ``cameras``: each camera's (image, window corners) now.
        """
        if mode == "state_pixels":
            return cameras[0][0]
        images = [image for image, _ in cameras]
        windows = [corners for _, corners in cameras]
        return self.overview().render(footprint_corners(self.car), windows, images)

    def ground_texture(self) -> GroundTexture:
        """The track picture the cameras see."""
        return self.prepared.texture

    def overview(self) -> Overview:
        if self.prepared.overview is None:
            cte = self.config.reward_design.cross_track_error
            color = cte.trajectory_color if cte.use_cte else None
            self.prepared.overview = Overview(self.track, self.config.sim.overview_downscale, color)
        return self.prepared.overview


class ImageCourse:
    """What lasts across resets: every track of the source, prepared once."""

    def __init__(self, config: EnvConfig, source: ImageSource, car_model: CarModel):
        self.config = config
        self.source = source
        self.car_model = car_model
        self.prepared: list[PreparedTrack] = []
        for layout in source.tracks:
            track: ImageTrack = layout.detail
            world = World()
            world.add_obstacle_cells(track.cells)
            self.prepared.append(PreparedTrack(track, GroundTexture.from_image(track.image), world))

    @property
    def tracks(self) -> list[ImageTrack]:
        return [p.track for p in self.prepared]

    def new_episode(self, draw: TrackDraw) -> ImageEpisode:
        prepared = self.prepared[draw.track_index]
        return ImageEpisode(self.config, prepared, draw, self.car_model)
