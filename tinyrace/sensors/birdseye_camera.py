"""Bird's-eye cameras fixed to the car, tinycarlo-style: a track window ahead of the car.

A camera sees ``roi`` = [y, x] track units: the window's bottom edge is centred
on the mount point (the front axle's middle shifted by ``position`` = [y, x],
+y ahead, +x to the right of the car, as tinycarlo shifts its crop), it extends
``roi[0]`` ahead along the camera's direction (the car's heading turned by ``yaw`` degrees,
positive to the right), and it is sampled at ``resolution`` = [y, x] pixels by
one affine warp of the ground texture.

``BirdseyeCamera`` is the sensor type ``birdseye_camera``; each entry of tinycarlo's
``cameras:`` list becomes one.
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np
from gymnasium import spaces

from tinyrace.config import CameraConfig
from tinyrace.ground.texture import GroundTexture, compose
from tinyrace.sensors.base import Ground, SensorContext, TopDown
from tinyrace.sensors.machinery.common import (
    GroundImage,
    PerTrack,
    label_names,
    label_table,
    paint_labels,
    shared_ground,
)
from tinyrace.sensors.machinery.draw_cars import CAR_LABEL, CarLooks, Paint, fill_footprints
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

Axes = tuple[float, float, float, float]  # forward x, y and right x, y unit vectors


class RoiCamera:
    """One configured camera on a ground texture; ``y_down`` for image tracks (pixels)."""

    def __init__(self, config: CameraConfig, texture: GroundTexture, y_down: bool):
        self.config = config
        self.texture = texture
        self.y_down = y_down
        self.size = (config.resolution[1], config.resolution[0])  # (w, h) for cv2
        ry, rx = config.roi
        self.scale = (self.size[0] / rx, self.size[1] / ry)  # output px per track unit
        self.pixels_per_unit = math.sqrt(self.scale[0] * self.scale[1])
        self.turn = math.radians(config.yaw)  # [rad] the camera's direction right of the car's

    def _axes(self, heading: float, turn: float) -> Axes:
        """Forward and right unit vectors of a direction ``turn`` [rad] right of ``heading``."""
        angle = heading + turn if self.y_down else heading - turn
        fx, fy = math.cos(angle), math.sin(angle)
        return (fx, fy, -fy, fx) if self.y_down else (fx, fy, fy, -fx)

    def mount(
        self, front: tuple[float, float], heading: float, car_axes: Axes | None = None
    ) -> tuple[float, float]:
        """The window's bottom-centre point in track units (``car_axes``: the car's, if known)."""
        fx, fy, rx, ry = car_axes or self._axes(heading, 0.0)
        ahead, right = self.config.position
        return front[0] + ahead * fx + right * rx, front[1] + ahead * fy + right * ry

    def matrix(self, front: tuple[float, float], heading: float) -> np.ndarray:
        """World -> output pixel affine for the car's front-axle middle and heading."""
        fx, fy, rx, ry = axes = self._axes(heading, self.turn)
        mx, my = self.mount(front, heading, axes if self.turn == 0 else None)
        sx, sy = self.scale
        roi_y, roi_x = self.config.roi
        # u = roi_x/2 + (p - m).right ; v = roi_y - (p - m).forward ; pixel index = u * sx - 0.5
        return np.array(
            [
                [sx * rx, sx * ry, sx * (roi_x / 2 - (mx * rx + my * ry)) - 0.5],
                [-sy * fx, -sy * fy, sy * (roi_y + (mx * fx + my * fy)) - 0.5],
            ]
        )

    def render(self, front: tuple[float, float], heading: float) -> np.ndarray:
        """The camera image (H, W, 3) uint8 RGB."""
        matrix = self.matrix(front, heading)
        return self.texture.warp(matrix, self.size, pixels_per_unit=self.pixels_per_unit)

    def corners(self, front: tuple[float, float], heading: float) -> np.ndarray:
        """(4, 2) window corners [track units]: bottom-left, bottom-right, top-right, top-left."""
        mx, my = self.mount(front, heading)
        fx, fy, rx, ry = self._axes(heading, self.turn)
        roi_y, roi_x = self.config.roi
        offsets = [(-roi_x / 2, 0), (roi_x / 2, 0), (roi_x / 2, roi_y), (-roi_x / 2, roi_y)]
        return np.array([(mx + a * rx + b * fx, my + a * ry + b * fy) for a, b in offsets])


class BirdseyeCamera:
    """The ``birdseye_camera`` sensor: the ground ahead of the car as an RGB, gray or class
    label image (``format``; labels as the perspective camera's, without a sky); the other
    cars of a race on the ground, each in its colour (``sensors/machinery/draw_cars.py``)."""

    def __init__(self, config: CameraConfig, ground: Ground, paints: tuple[Paint, ...] = ()):
        self.config = config
        self.ground = ground
        self.paints = paints  # each car's paint in this format, by its index in the world
        channels = (3,) if config.format == "rgb" else ()
        self.space = spaces.Box(0, 255, (*config.resolution, *channels), np.uint8)
        self._camera: RoiCamera | None = None  # on the current episode's ground
        self._labels: PerTrack[tuple[GroundImage, dict[int, str]]] = PerTrack()  # classes
        self._names: dict[int, str] = {}  # by label value, on the current track

    @property
    def id(self) -> str:
        return self.config.id

    @property
    def labels(self) -> dict[int, str]:
        """The name of each label value of a ``classes`` image on the current track (a new
        dict each time: infos never share it)."""
        return dict(self._names)

    def describe(self) -> str:
        c = self.config
        return f"bird's-eye camera, {c.format}, a {c.roi[0]:g} x {c.roi[1]:g} window ahead"

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        return TopDown(self.window(snapshot, track))

    def reset(self, track: Track) -> None:
        self._camera = None  # a new episode may have a new ground
        if self.config.format == "classes":
            self._label_ground, self._names = self._labels.get(track, self._paint_labels)
            if len(self.paints) > 1:  # a race: the other cars are labelled too
                self._names = {**self._names, CAR_LABEL: "car"}

    def _paint_labels(self, track: Track) -> tuple[GroundImage, dict[int, str]]:
        table = label_table(track)
        ppu = self.camera(track).pixels_per_unit  # [label px per track unit] as the output's
        ground = shared_ground(track, "labels", ppu, lambda: paint_labels(track, table, ppu))
        return ground, label_names(table)

    def camera(self, track: Track) -> RoiCamera:
        """The camera on the current episode's ground texture."""
        if self._camera is None:
            self._camera = RoiCamera(self.config, self.ground.texture(track), track.y_down)
        return self._camera

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> np.ndarray:
        car = snapshot.car
        camera = self.camera(track)
        if self.config.format == "classes":  # labels: nearest sample, never blended
            ground = self._label_ground
            to_out = camera.matrix(car.front_axle, car.pose[2])
            matrix = compose(to_out, cv2.invertAffineTransform(ground.to_pixels))
            labels = cv2.warpAffine(
                ground.image, matrix, camera.size, flags=cv2.INTER_NEAREST, borderValue=0
            )
            if len(snapshot.cars) > 1:
                fill_footprints(labels, to_out, snapshot, self.paints, antialias=False)
            return labels
        image = camera.render(car.front_axle, car.pose[2])
        if len(snapshot.cars) > 1:  # a race: the others, in their colours
            to_out = camera.matrix(car.front_axle, car.pose[2])
            fill_footprints(image, to_out, snapshot, self.paints)
        return image if self.config.format == "rgb" else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)

    def window(self, snapshot: Snapshot, track: Track) -> np.ndarray:
        """(4, 2) corners of the track window it sees [track units], for pictures."""
        car = snapshot.car
        return self.camera(track).corners(car.front_axle, car.pose[2])

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_camera": None}  # the texture belongs to the episode


def build(entry: CameraConfig, context: SensorContext) -> BirdseyeCamera:
    """A ``birdseye_camera`` from its config entry (a ``cameras:`` item)."""
    paints = CarLooks.of(context.env).paints("classes" if entry.format == "classes" else "rgb")
    return BirdseyeCamera(entry, context.ground, paints)
