"""``type: perspective_camera``: a pinhole camera on the car (see ``sensors/machinery/pinhole.py``).

Formats: ``rgb`` (H, W, 3) uint8; ``gray`` (H, W) uint8; ``classes`` (H, W) uint8 labels
of the track's ground, sampled without interpolation so that no pixel blends two labels.
Labels (``label_table``): 0 background, 1 road (tracks with road surfaces), then each
obstacle colour of a picture track, then the picture's other colours (markings); 255 sky.
The table of the current track, {label: name} with the sky, is ``labels`` (and
``info['sensor_labels'][id]``).
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np
from gymnasium import spaces

from tinyrace.config.sensors import PerspectiveCameraConfig
from tinyrace.sensors.base import Ground as EpisodeGround
from tinyrace.sensors.base import SensorContext, TopDown
from tinyrace.sensors.machinery.common import (
    GroundImage,
    PerTrack,
    Unsupported,
    label_names,
    label_table,
    paint_labels,
    shared_ground,
)
from tinyrace.sensors.machinery.draw_cars import CAR_LABEL, CarLooks, Paint, fill_footprints_seen
from tinyrace.sensors.machinery.pinhole import (
    Pinhole,
    car_to_world,
    render,
    warp_below_sky,
    world_to_car,
)
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

DEFAULT_HEIGHT = 0.4  # [car lengths] camera height when no position is given
DEFAULT_FOV = 90.0  # [deg] horizontal field of view without fov, intrinsics or camera_info
SKY_LABEL = 255  # the ``classes`` label of pixels above the horizon or beyond max_range


class PerspectiveCamera:
    """A pinhole camera fixed to the car's front axle."""

    def __init__(
        self,
        config: PerspectiveCameraConfig,
        length: float,
        pixels_per_unit: float,
        episode_ground: EpisodeGround,
        paints: tuple[Paint, ...] = (),
    ):
        self.config = config
        self.paints = paints  # each car's paint in this format, by its index in the world
        self.episode_ground = episode_ground  # the cameras' shared texture of the episode
        h, w = config.resolution
        x, y, z = config.position or (0.0, 0.0, DEFAULT_HEIGHT * length)
        if config.camera_info is not None and config.intrinsics is None:
            raise Unsupported(
                f"camera_info: {config.camera_info} is read when a config is loaded from a "
                "file or dict (tinyrace.config.load_env_config), not from a parsed EnvConfig"
            )
        fov = config.fov if config.fov is not None else DEFAULT_FOV
        self.pinhole = Pinhole(
            (w, h),
            math.radians(fov),
            (x, -y, z),  # the core's frame: ahead, right, up
            yaw=-math.radians(config.yaw),  # the core turns + right
            pitch=math.radians(config.pitch),
            roll=math.radians(config.roll),
            max_range=config.max_range,
            matrix=config.intrinsics,
            distortion=config.distortion,
        )
        self.pixels_per_unit = pixels_per_unit  # ground texture of tracks without a picture
        shape = (h, w, 3) if config.format == "rgb" else (h, w)
        self.space = spaces.Box(0, 255, shape, np.uint8)
        self._grounds: PerTrack[tuple[GroundImage, dict[int, str]]] = PerTrack()
        self.ground: GroundImage | None = None
        self._names: dict[int, str] = {}  # by label value, on the current track
        self._scratch: np.ndarray | None = None  # RGBx warp of the rows below the sky
        self._conversion = cv2.COLOR_RGBA2RGB if config.format == "rgb" else cv2.COLOR_RGBA2GRAY
        # the sky in the output format (gray: as cv2 converts the sky colour)
        sky = cv2.cvtColor(np.array([[(*config.sky_color, 255)]], np.uint8), self._conversion)
        self._sky = self.pinhole.sky_paint(tuple(sky.reshape(-1).tolist()), shape[2:])

    @property
    def id(self) -> str:
        return self.config.id

    @property
    def labels(self) -> dict[int, str]:
        """The name of each label value of a ``classes`` image on the current track (a new
        dict each time: infos never share it)."""
        return dict(self._names)

    def describe(self) -> str:
        return f"perspective camera, {self.config.format}, pitched {self.config.pitch:g} deg"

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        return None  # its observation is no picture from above

    def reset(self, track: Track) -> None:
        if self.config.format == "classes":
            self.ground, self._names = self._grounds.get(track, self._paint_labels)
            if len(self.paints) > 1:  # a race: the other cars are labelled too
                self._names = {**self._names, CAR_LABEL: "car"}
        else:  # the episode's own ground (CarRacing's tiles and grass, or the picture)
            texture = self.episode_ground.texture(track)
            self.ground = GroundImage(texture.image(0), texture.to_pixels[0])

    def _paint_labels(self, track: Track) -> tuple[GroundImage, dict[int, str]]:
        table = label_table(track)
        names = {**label_names(table), SKY_LABEL: "sky"}
        ppu = self.pixels_per_unit
        return shared_ground(track, "labels", ppu, lambda: paint_labels(track, table, ppu)), names

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> np.ndarray:
        car = snapshot.car
        placed = car_to_world(car.front_axle, car.pose[2], track.y_down)
        ground = self.ground
        assert ground is not None, "reset() before observe()"
        if self.config.format == "classes":
            labels = render(
                self.pinhole,
                ground.image,
                ground.to_pixels,
                placed,
                (SKY_LABEL,),
                cv2.INTER_NEAREST,
            )
            if len(snapshot.cars) > 1:  # a race: the other cars, then the sky over them
                self._draw_others(labels, snapshot, track, antialias=False)
                self.pinhole.sky_paint((SKY_LABEL,)).paint(labels)
            return labels
        return self._colors(ground, placed, snapshot, track)

    def _draw_others(
        self, image: np.ndarray, snapshot: Snapshot, track: Track, antialias: bool = True
    ) -> None:
        """The other cars of a race on the ground (``sensors/machinery/draw_cars.py``)."""
        car = snapshot.car
        to_car = world_to_car(car.front_axle, car.pose[2], track.y_down)
        fill_footprints_seen(image, self.pinhole, to_car, snapshot, self.paints, antialias)

    def _colors(
        self, ground: GroundImage, placed: np.ndarray, snapshot: Snapshot, track: Track
    ) -> np.ndarray:
        """The ``rgb`` or ``gray`` image: the ground below the sky rows warped in RGBx (cv2's
        fast layout) into a buffer that is converted straight into the new image."""
        width, height = self.pinhole.size
        rows = self.pinhole.sky_rows
        image = np.empty(self.space.shape, np.uint8)
        if rows < height:
            if self._scratch is None:
                self._scratch = np.empty((height - rows, width, 4), np.uint8)
            scratch = self._scratch
            warp_below_sky(
                self.pinhole, ground.image, ground.to_pixels, placed, cv2.INTER_LINEAR, scratch
            )
            below = image[rows:]
            converted = cv2.cvtColor(scratch, self._conversion, dst=below)
            assert converted is below, "cv2 wrote into its own array"
        if len(snapshot.cars) > 1:  # a race: the other cars, under the sky
            self._draw_others(image, snapshot, track)
        self._sky.paint(image)
        return image

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_scratch": None}  # a warp buffer, made again on first use


def build(config: PerspectiveCameraConfig, context: SensorContext) -> PerspectiveCamera:
    """The camera of ``config``; tracks without a picture are drawn at the procedural
    track's ``pixels_per_unit`` (8 px per car length on other sources)."""
    env = context.env
    length = context.car.length
    track = env.tracks[0]
    ppu = getattr(track, "pixels_per_unit", None) or 8.0 / length
    paints = CarLooks.of(env).paints(config.format)
    return PerspectiveCamera(config, length, ppu, context.ground, paints)
