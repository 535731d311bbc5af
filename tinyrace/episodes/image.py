"""Episodes on image tracks: obstacle colours under the footprint, distance to a trajectory."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tinyrace.cars.dynamic import DynamicCar
from tinyrace.cars.kinematic import KinematicCar
from tinyrace.config import EnvConfig
from tinyrace.episodes import StepFacts
from tinyrace.errors import ConfigError, Problem
from tinyrace.render.overview import Overview
from tinyrace.render.texture import GroundTexture
from tinyrace.sensors.birdseye_camera import RoiCamera
from tinyrace.tracks.image import ImageTrack, load_image_track, touched_obstacles
from tinyrace.world.world import World

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


@dataclass(eq=False)
class PreparedTrack:
    """One track, prepared once per env: its data, ground texture, pymunk world (obstacle
    sensors) and, when first drawn, its overview."""

    track: ImageTrack
    texture: GroundTexture
    world: World
    overview: Overview | None = None


class ImageEpisode:
    """One reset on an image track: the chosen track and spawn, a car in its world, cameras."""

    def __init__(
        self, config: EnvConfig, prepared: PreparedTrack, track_index: int, spawn_index: int
    ):
        self.config = config
        self.prepared = prepared
        self.track = prepared.track
        self.track_index, self.spawn_index = track_index, spawn_index
        self.world = prepared.world
        self.world.remove_cars()  # the last episode's car; the obstacle sensors stay
        self.car = build_car(config, self.world, self.track.spawns[spawn_index])
        self.cameras = [RoiCamera(c, prepared.texture, y_down=True) for c in config.cameras]
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
        if self.prepared.overview is None:
            cte = self.config.reward_design.cross_track_error
            color = cte.trajectory_color if cte.use_cte else None
            self.prepared.overview = Overview(self.track, self.config.sim.overview_downscale, color)
        return self.prepared.overview


class ImageCourse:
    """What lasts across resets: every track image, loaded and prepared once."""

    def __init__(self, config: EnvConfig, base_dir: Path, source: str):
        self.config = config
        self.prepared: list[PreparedTrack] = []
        problems = []
        for index, track_config in enumerate(config.tracks):
            track, found = load_image_track(track_config, index, config, base_dir, source)
            problems += found
            if track is not None:
                world = World()
                world.add_obstacle_cells(track.cells)
                self.prepared.append(
                    PreparedTrack(track, GroundTexture.from_image(track.image, exact_colors=True), world)
                )
        if problems:
            raise ConfigError(problems)

    @property
    def tracks(self) -> list[ImageTrack]:
        return [p.track for p in self.prepared]

    def new_episode(self, rng: np.random.Generator, options: dict) -> ImageEpisode:
        """A track then a spawn, each drawn from ``rng`` unless ``options`` picks it."""
        track_index = _pick(options, "track", len(self.prepared), rng)
        spawn_index = _pick(options, "spawn", len(self.prepared[track_index].track.spawns), rng)
        return ImageEpisode(self.config, self.prepared[track_index], track_index, spawn_index)


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
