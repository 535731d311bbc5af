"""Episodes on image tracks: obstacle colours under the footprint, distance to a trajectory."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from tinyrace.config import EnvConfig
from tinyrace.episodes import StepFacts
from tinyrace.errors import ConfigError, Problem
from tinyrace.physics.dynamic_car import DynamicCar
from tinyrace.physics.kinematic_car import KinematicCar
from tinyrace.physics.world import World
from tinyrace.render.overview import Overview
from tinyrace.render.roi_camera import RoiCamera
from tinyrace.render.texture import GroundTexture
from tinyrace.track.image import ImageTrack, load_image_track, touched_obstacles

_ALL_ROAD = (True, True, True, True)  # image tracks have no grass: full grip everywhere


def build_car(config: EnvConfig, world: World, pose: tuple[float, float, float]):
    """The configured car model at ``pose`` (x px, y px, heading rad) on a y-down image."""
    car = config.car
    if car.model == "dynamic":
        return DynamicCar.build(world.space, pose, scale=car.pixels_per_unit, y_down=True)
    return KinematicCar.build(
        world.space,
        pose,
        car.wheelbase,
        car.track_width,
        car.velocity,
        car.max_steering_angle,
        car.max_steering_change,
    )


def footprint_corners(car) -> np.ndarray:
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


class ImageEpisode:
    """One reset on an image track: the chosen track and spawn, a world, a car, cameras."""

    def __init__(
        self,
        config: EnvConfig,
        track: ImageTrack,
        texture: GroundTexture,
        track_index: int,
        spawn_index: int,
        overviews: dict[int, Overview],
    ):
        self.config = config
        self.track = track
        self.track_index, self.spawn_index = track_index, spawn_index
        self.world = World()
        self.world.add_obstacle_cells(track.cells)
        self.car = build_car(config, self.world, track.spawns[spawn_index])
        self.cameras = [RoiCamera(c, texture, y_down=True) for c in config.cameras]
        self._overviews = (
            overviews  # shared with the course: built once per track, when first drawn
        )
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
        self.car.apply_forces(dt, _ALL_ROAD)
        return self._sense(dt)

    def _sense(self, dt: float) -> StepFacts:
        contacts = self.world.step(dt)
        self.car.after_step(dt)
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

    def info(self) -> dict:
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

    def observe(self, t: float, score: float) -> dict[str, np.ndarray]:
        front, heading = self.car.front_axle, self.car.pose[2]
        return {camera.config.id: camera.render(front, heading) for camera in self.cameras}

    def frame(self, mode: str, t: float, score: float) -> np.ndarray:
        """state_pixels: the first camera; rgb_array and human: the overview."""
        images = self.observe(t, score)
        if mode == "state_pixels":
            return next(iter(images.values()))
        front, heading = self.car.front_axle, self.car.pose[2]
        windows = [camera.corners(front, heading) for camera in self.cameras]
        return self.overview().render(footprint_corners(self.car), windows, list(images.values()))

    def overview(self) -> Overview:
        overview = self._overviews.get(self.track_index)
        if overview is None:
            cte = self.config.reward_design.cross_track_error
            color = cte.trajectory_color if cte.use_cte else None
            overview = Overview(self.track, self.config.sim.overview_downscale, color)
            self._overviews[self.track_index] = overview
        return overview


class ImageCourse:
    """What lasts across resets: every track image, loaded and prepared once."""

    def __init__(self, config: EnvConfig, base_dir: Path, source: str):
        self.config = config
        tracks, textures, problems = [], [], []
        for index, track_config in enumerate(config.tracks):
            track, found = load_image_track(track_config, index, config, base_dir, source)
            problems += found
            if track is not None:
                tracks.append(track)
                textures.append(GroundTexture.from_image(track.image))
        if problems:
            raise ConfigError(problems)
        self.tracks, self.textures = tracks, textures
        self._overviews: dict[int, Overview] = {}

    def new_episode(self, rng: np.random.Generator, options: dict) -> ImageEpisode:
        """A track then a spawn, each drawn from ``rng`` unless ``options`` picks it."""
        track_index = _pick(options, "track", len(self.tracks), rng)
        spawn_index = _pick(options, "spawn", len(self.tracks[track_index].spawns), rng)
        return ImageEpisode(
            self.config,
            self.tracks[track_index],
            self.textures[track_index],
            track_index,
            spawn_index,
            self._overviews,
        )


def _pick(options: dict, key: str, count: int, rng: np.random.Generator) -> int:
    drawn = int(
        rng.integers(count)
    )  # drawn even when chosen, so that choosing changes nothing else
    chosen = options.get(key)
    if chosen is None:
        return drawn
    if (
        isinstance(chosen, bool)
        or not isinstance(chosen, (int, np.integer))
        or not 0 <= chosen < count
    ):
        raise ConfigError(
            Problem("<reset options>", key, chosen, f"expected a {key} index from 0 to {count - 1}")
        )
    return int(chosen)
