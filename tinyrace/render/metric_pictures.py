"""The pictures of a track in metres: its painted ground, a default top view, the overview."""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from tinyrace.cars.state import footprint_corners
from tinyrace.config import CameraConfig, EnvConfig, cache_settings
from tinyrace.render.metric_ground import MetricOverview, shared_ground
from tinyrace.render.pictures import CameraViews
from tinyrace.sensors.birdseye_camera import RoiCamera
from tinyrace.sensors.draw_cars import CarLooks, fill_footprints
from tinyrace.sensors.texture import GroundTexture, transform_points
from tinyrace.tracks.base import TrackDraw
from tinyrace.tracks.metric import MetricSource, MetricTrack
from tinyrace.world.snapshot import Snapshot

DEFAULT_VIEW = (96, 96)  # [px] (h, w) the observation when no camera is configured
VIEW_SPAN = 14.0  # [wheelbases] the default view's side
CAR_COLOR = (204, 0, 0)  # RGB, the car drawn into the default view
DEFAULT_PIXELS_PER_METER = 20.0  # [px/m] when the track config names none


class MetricPictures:
    """Every track's ground texture and overview, each made when first read (a camera,
    the default view or a frame); textures are shared with the other envs of the track."""

    def __init__(self, config: EnvConfig, source: MetricSource):
        self.layouts = source.tracks
        self.tracks: list[MetricTrack] = [layout.detail for layout in source.tracks]
        self.scales = [  # [px/m] of each track's texture
            getattr(track_config, "pixels_per_meter", DEFAULT_PIXELS_PER_METER)
            for track_config in config.tracks
        ]
        self.cache = cache_settings(config)
        self.textures: list[GroundTexture | None] = [None] * len(self.tracks)
        self.overviews: list[MetricOverview | None] = [None] * len(self.tracks)
        self.index = 0  # the current episode's track
        self.view: RoiCamera | None = None  # the default view, made at the first observation
        self.looks = CarLooks.of(config)  # the colours and names of a race's cars

    def reset(self, draw: TrackDraw, visited: Sequence[int]) -> None:
        self.index, self.view = draw.track_index, None

    def observe(self, snapshot: Snapshot, score: float) -> np.ndarray:
        """The observation without cameras: a 96x96 top view of the road ahead, with the car."""
        car = snapshot.car
        view = self.view or self._default_view(car.footprint[0])
        front, heading = car.front_axle, car.pose[2]
        image = view.render(front, heading)
        matrix = view.matrix(front, heading)
        if len(snapshot.cars) > 1:  # a race: the other cars in their colours
            fill_footprints(image, matrix, snapshot, self.looks.colors)
        corners = transform_points(matrix, footprint_corners(car))
        cv2.fillConvexPoly(
            image, np.round(corners * 16).astype(np.int32), CAR_COLOR, cv2.LINE_AA, 4
        )
        return image

    def _default_view(self, wheelbase: float) -> RoiCamera:
        span = VIEW_SPAN * wheelbase  # [m]
        view = CameraConfig(
            id="view", resolution=DEFAULT_VIEW, roi=(span, span), position=(-span / 4, 0.0)
        )
        self.view = RoiCamera(view, self.ground_texture(), y_down=False)
        return self.view

    def frame(
        self, mode: str, snapshot: Snapshot, score: float, cameras: CameraViews = ()
    ) -> np.ndarray:
        """state_pixels: the first camera or the default view; rgb_array and human: the
        overview. ``cameras``: each camera's (image, window corners) now."""
        images = [image for image, _ in cameras] or [self.observe(snapshot, score)]
        if mode == "state_pixels":
            return images[0]
        windows = [corners for _, corners in cameras]
        overview = self.overviews[self.index]
        if overview is None:
            overview = MetricOverview(self.tracks[self.index], self.ground_texture())
            self.overviews[self.index] = overview
        race = (snapshot, self.looks)
        return overview.render(footprint_corners(snapshot.car), windows, images, race)

    def ground_texture(self) -> GroundTexture:
        """The track picture the cameras see (painted, or mapped, at its first read)."""
        texture = self.textures[self.index]
        if texture is None:
            i = self.index
            texture = shared_ground(self.layouts[i], self.tracks[i], self.scales[i], self.cache)
            self.textures[i] = texture
        return texture
