"""A top view of the road ahead with the car drawn in: the default observation of a track in
metres (the sensor type ``top_view``).

The window is a square of ``span`` wheelbases, a quarter of it behind the front axle, turned
with the car; the ground is sampled by one affine warp, the other cars of a race are filled
in their colours (``sensors/machinery/draw_cars.py``) and the car's footprint on top in
CarRacing's red.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from gymnasium import spaces

from tinyrace.cars.state import footprint_corners
from tinyrace.config import CameraConfig
from tinyrace.config.sensors import TopViewConfig
from tinyrace.ground.texture import GroundTexture, transform_points
from tinyrace.sensors.base import Ground, SensorContext, TopDown
from tinyrace.sensors.birdseye_camera import RoiCamera
from tinyrace.sensors.machinery.draw_cars import CarLooks, Paint, fill_footprints
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

CAR_COLOR = (204, 0, 0)  # RGB, the car drawn into the view
_BITS = 4  # cv2 fixed-point vertices: 1/16 px


class TopView:
    """The view on one ground texture; its window is sized by the first car it sees."""

    def __init__(
        self, config: TopViewConfig, texture: GroundTexture, paints: tuple[Paint, ...] = ()
    ):
        self.config = config
        self.texture = texture
        self.paints = paints  # each car's colour, by its index in the world
        self._camera: RoiCamera | None = None

    def render(self, snapshot: Snapshot) -> np.ndarray:
        """(H, W, 3) uint8 RGB: the ground around ``snapshot``'s car with the other cars and
        its own footprint filled in."""
        car = snapshot.car
        camera = self._camera or self._make_camera(car.footprint[0])
        front, heading = car.front_axle, car.pose[2]
        image = camera.render(front, heading)
        matrix = camera.matrix(front, heading)
        if len(snapshot.cars) > 1:  # a race: the other cars in their colours
            fill_footprints(image, matrix, snapshot, self.paints)
        corners = transform_points(matrix, footprint_corners(car))
        pixels = np.round(corners * (1 << _BITS)).astype(np.int32)
        cv2.fillConvexPoly(image, pixels, CAR_COLOR, cv2.LINE_AA, _BITS)
        return image

    def _make_camera(self, wheelbase: float) -> RoiCamera:
        span = self.config.span * wheelbase  # [m]
        window = CameraConfig(
            id=self.config.id,
            resolution=self.config.resolution,
            roi=(span, span),
            position=(-span / 4, 0.0),
        )
        self._camera = RoiCamera(window, self.texture, y_down=False)
        return self._camera


class TopViewSensor:
    """The ``top_view`` sensor: a ``TopView`` of the current episode's ground."""

    def __init__(self, config: TopViewConfig, ground: Ground, paints: tuple[Paint, ...] = ()):
        self.config = config
        self.ground = ground
        self.paints = paints  # each car's colour, by its index in the world
        self.space = spaces.Box(0, 255, (*config.resolution, 3), np.uint8)
        self._view: TopView | None = None  # on the current episode's ground

    @property
    def id(self) -> str:
        return self.config.id

    def describe(self) -> str:
        return f"the road from above, {self.config.span:g} wheelbases across, the car drawn in"

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        return TopDown()  # turned with the car: no window drawn on the overview

    def reset(self, track: Track) -> None:
        self._view = None  # a new episode may have a new ground

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> np.ndarray:
        view = self._view
        if view is None:
            view = self._view = TopView(self.config, self.ground.texture(track), self.paints)
        return view.render(snapshot)

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_view": None}  # the texture belongs to the episode


def build(entry: TopViewConfig, context: SensorContext) -> TopViewSensor:
    """A ``top_view`` sensor from its config entry."""
    return TopViewSensor(entry, context.ground, CarLooks.of(context.env).colors)
