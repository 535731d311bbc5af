"""A picture of what the sensors saw: a top-down map around the car with the lidar's rays,
the detected cones and the lookahead points drawn on it, and every camera-like sensor's
image beside it (perspective views; ``classes`` images in false colours).

It reads the snapshot, the track and the observation only; the map is the track's ground
drawn once per track (``tinyrace.sensors.machinery.common``), turned so that the car points up.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Protocol
from weakref import WeakKeyDictionary

import cv2
import numpy as np

from tinyrace.cars.state import CarFacts
from tinyrace.config import EnvConfig
from tinyrace.sensors.base import Sensor
from tinyrace.sensors.cones import ConesSensor
from tinyrace.sensors.lidar import LidarSensor
from tinyrace.sensors.lookahead import LookaheadSensor
from tinyrace.sensors.machinery.common import GroundImage, PerTrack, paint_colors, shared_ground
from tinyrace.sensors.machinery.draw_cars import CarLooks, draw_race
from tinyrace.sensors.perspective_camera import PerspectiveCamera
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

SIZE = 360  # [px] side of the square map
RAY_COLOR = (255, 60, 60)  # RGB
LOOKAHEAD_COLOR = (255, 0, 255)
CAR_COLOR = (255, 255, 255)
CONE_COLORS = {1: (40, 90, 255), 2: (255, 220, 0), 3: (255, 140, 0)}  # by class
_BITS = 3

Point = Sequence[float] | np.ndarray  # (x, y)


class SensorHost(Protocol):
    """What the view needs of an env: its config, its car's facts and its sensors."""

    config: EnvConfig
    car_facts: CarFacts
    sensors: list[Sensor]


_VIEWS: WeakKeyDictionary[SensorHost, SensorView] = WeakKeyDictionary()  # one per env


class SensorView:
    """Draws sensor frames; ``reach`` [track units] from the car to the map's edge."""

    def __init__(
        self,
        sensors: list[Sensor],
        reach: float,
        pixels_per_unit: float,
        looks: CarLooks | None = None,
    ):
        self.sensors = sensors
        self.looks = looks  # a race's colours and names: the other cars drawn and named
        self.reach = reach
        self.pixels_per_unit = pixels_per_unit  # of the ground drawn for tracks without pictures
        self._grounds: PerTrack[GroundImage] = PerTrack()

    def render(self, snapshot: Snapshot, track: Track, observation: dict[str, Any]) -> np.ndarray:
        """(SIZE, SIZE + images, 3) uint8 RGB."""
        ppu = self.pixels_per_unit
        ground = self._grounds.get(
            track, lambda t: shared_ground(t, "colours", ppu, lambda: paint_colors(t, ppu))
        )
        car = snapshot.car
        to_view = self._car_to_view()  # car frame (ahead, left) -> view px
        world_to_car = _world_to_car(car.front_axle, car.pose[2], track.y_down)
        car_to_world = cv2.invertAffineTransform(world_to_car)
        view_to_car = cv2.invertAffineTransform(to_view)
        view_to_texture = _compose(ground.to_pixels, _compose(car_to_world, view_to_car))
        frame = cv2.warpAffine(
            ground.image,
            view_to_texture,
            (SIZE, SIZE),
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        )
        frame = cv2.cvtColor(frame, cv2.COLOR_RGBA2RGB)
        if self.looks is not None and len(snapshot.cars) > 1:
            draw_race(frame, _compose(to_view, world_to_car), snapshot, self.looks)
        for sensor in self.sensors:
            self._draw(frame, sensor, observation.get(sensor.id), snapshot, track, to_view)
        cv2.circle(frame, _px(to_view, (0.0, 0.0)), 4, CAR_COLOR, -1, cv2.LINE_AA, _BITS)
        images = [
            _picture(observation[s.id], s.config.format)
            for s in self.sensors
            if isinstance(s, PerspectiveCamera)
        ]
        return _beside(frame, images)

    def _car_to_view(self) -> np.ndarray:
        """(2x3) car frame (ahead, left) -> view px: the car at the centre, ahead is up."""
        s = SIZE / (2 * self.reach)
        return np.array([[0.0, -s, SIZE / 2], [-s, 0.0, SIZE / 2]])

    def _draw(
        self,
        frame: np.ndarray,
        sensor: Sensor,
        value: Any,
        snapshot: Snapshot,
        track: Track,
        to_view: np.ndarray,
    ) -> None:
        if value is None:
            return
        if isinstance(sensor, LidarSensor):
            ranges = value["ranges"] if isinstance(value, dict) else value  # hit_classes: Dict
            origin = _local(snapshot, track, sensor.origin(snapshot, track))
            ends = origin + ranges[:, None] * np.stack(
                [np.cos(sensor.angles), np.sin(sensor.angles)], axis=1
            )
            start = _px(to_view, origin)
            rays = [
                np.array([start, _px(to_view, end)], np.int32)
                for end in ends[:: max(1, len(ends) // 180)]
            ]
            cv2.polylines(frame, rays, False, RAY_COLOR, 1, cv2.LINE_AA, _BITS)
        elif isinstance(sensor, ConesSensor):
            for x, y, cls in value["cones"][: value["count"]]:
                color = CONE_COLORS.get(int(cls), (255, 255, 255))
                cv2.circle(frame, _px(to_view, (x, y)), 5 << _BITS, color, 2, cv2.LINE_AA, _BITS)
        elif isinstance(sensor, LookaheadSensor):
            for x, y, _ in value:
                cv2.circle(
                    frame, _px(to_view, (x, y)), 3 << _BITS, LOOKAHEAD_COLOR, -1, cv2.LINE_AA, _BITS
                )


def _compose(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """The 2x3 affine ``outer`` after ``inner``."""
    composed: np.ndarray = outer @ np.vstack([inner, [0.0, 0.0, 1.0]])
    return composed


def _world_to_car(front: Point, heading: float, y_down: bool) -> np.ndarray:
    """(2x3) track point -> car frame (ahead, left)."""
    c, s = math.cos(heading), math.sin(heading)
    lx, ly = (s, -c) if y_down else (-s, c)
    x, y = front
    return np.array([[c, s, -(x * c + y * s)], [lx, ly, -(x * lx + y * ly)]])


def _local(snapshot: Snapshot, track: Track, point: Point) -> np.ndarray:
    """A track point in the car frame (ahead, left) of the front axle."""
    car = snapshot.car
    to_car = _world_to_car(car.front_axle, car.pose[2], track.y_down)
    local: np.ndarray = to_car @ (point[0], point[1], 1.0)
    return local


def _px(to_view: np.ndarray, point: Point) -> tuple[int, int]:
    x, y = to_view @ (float(point[0]), float(point[1]), 1.0)
    return round(x * (1 << _BITS)), round(y * (1 << _BITS))


def _picture(image: np.ndarray, format: str) -> np.ndarray:
    """RGB: grey images as grey, label images in false colours (the sky, 255, stays white)."""
    if format == "rgb":
        return image
    if format == "classes":
        spread = ((image.astype(np.int32) * 47) % 200 + 40).astype(np.uint8)
        colored: np.ndarray = cv2.applyColorMap(spread, cv2.COLORMAP_JET)[..., ::-1].copy()
        colored[image == 255] = 255
        return colored
    return cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)


def _beside(frame: np.ndarray, images: list[np.ndarray]) -> np.ndarray:
    """``frame`` with the images stacked in a column to its right, scaled to fit."""
    if not images:
        return frame
    height = frame.shape[0] // len(images)
    column = []
    for image in images:
        scale = height / image.shape[0]
        size = (max(1, round(image.shape[1] * scale)), height)
        column.append(cv2.resize(image, size, interpolation=cv2.INTER_NEAREST))
    width = max(c.shape[1] for c in column)
    panel = np.zeros((frame.shape[0], width, 3), np.uint8)
    for k, image in enumerate(column):
        panel[k * height : k * height + image.shape[0], : image.shape[1]] = image
    return np.concatenate([frame, panel], axis=1)


def sensor_view(env: SensorHost) -> SensorView:
    """The env's sensor view, made on first use: the map reaches as far as the farthest
    sensor range (at least 3 car lengths)."""
    view = _VIEWS.get(env)
    if view is None:
        length = env.car_facts.length
        ranges = [float(getattr(s, "max_range", 0.0) or 0.0) for s in env.sensors]
        reach = max([3 * length, *[r for r in ranges if r < 100 * length]])
        looks = CarLooks.of(env.config)
        view = _VIEWS[env] = SensorView(env.sensors, reach, 16.0 / length, looks)
    return view
