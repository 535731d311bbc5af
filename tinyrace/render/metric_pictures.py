"""The pictures of a track in metres: the overview, with the default top view when no image
sensor drew one (its ground is the episode's, ``tinyrace.ground.grounds``)."""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from tinyrace.cars.state import footprint_corners
from tinyrace.config import EnvConfig
from tinyrace.config.sensors import TopViewConfig
from tinyrace.ground.grounds import EpisodeGround
from tinyrace.ground.texture import GroundTexture, transform_points
from tinyrace.render.pictures import CameraViews
from tinyrace.sensors.machinery.draw_cars import CarLooks, draw_race
from tinyrace.sensors.top_view import TopView
from tinyrace.tracks.base import Track, TrackDraw
from tinyrace.world.snapshot import Snapshot

_OVERVIEW_BITS = 4  # cv2 fixed-point vertices: 1/16 px


class MetricPictures:
    """Every track's overview, made when first drawn."""

    def __init__(self, config: EnvConfig, ground: EpisodeGround):
        self.ground = ground
        self.tracks: Sequence[Track] = ground.tracks
        self.overviews: list[MetricOverview | None] = [None] * len(self.tracks)
        self.index = 0  # the current episode's track
        self.view: TopView | None = None  # the default view, when no image sensor drew one
        self.looks = CarLooks.of(config)  # the colours and names of a race's cars

    def reset(self, draw: TrackDraw) -> None:
        self.index, self.view = draw.track_index, None

    def frame(self, mode: str, snapshot: Snapshot, cameras: CameraViews = ()) -> np.ndarray:
        """state_pixels: the first image sensor's view (else the default top view); rgb_array
        and human: the overview. ``cameras``: each image sensor's (image, window corners)."""
        images = [image for image, _ in cameras] or [self._default_view(snapshot)]
        if mode == "state_pixels":
            return images[0]
        windows = [corners for _, corners in cameras if corners is not None]
        overview = self.overviews[self.index]
        if overview is None:
            texture = self.ground.texture(self.tracks[self.index])
            overview = MetricOverview(self.tracks[self.index], texture)
            self.overviews[self.index] = overview
        race = (snapshot, self.looks)
        return overview.render(footprint_corners(snapshot.car), windows, images, race)

    def _default_view(self, snapshot: Snapshot) -> np.ndarray:
        """The top view a config without image sensors observes by default."""
        if self.view is None:
            texture = self.ground.texture(self.tracks[self.index])
            self.view = TopView(TopViewConfig(id="top_view"), texture, self.looks.colors)
        return self.view.render(snapshot)


class MetricOverview:
    """The whole track scaled to ``max_side`` px, the reference line, the car and camera views."""

    def __init__(self, track: Track, texture: GroundTexture, max_side: int = 800):
        x0, y0, x1, y1 = track.bounds
        self.scale = max_side / max(x1 - x0, y1 - y0)  # [px/m]
        self.size = (max(round((x1 - x0) * self.scale), 1), max(round((y1 - y0) * self.scale), 1))
        self.matrix = np.array(
            [[self.scale, 0.0, -x0 * self.scale], [0.0, -self.scale, y1 * self.scale]]
        )
        self.background = texture.warp(self.matrix, self.size)
        if track.centerline is not None:
            line = self._pixels(np.vstack((track.centerline, track.centerline[:1])))
            cv2.polylines(
                self.background, [line], False, (255, 255, 255), 1, cv2.LINE_AA, _OVERVIEW_BITS
            )

    def render(
        self,
        footprint: np.ndarray,
        windows: list[np.ndarray],
        images: list[np.ndarray],
        race: tuple[Snapshot, CarLooks] | None = None,
    ) -> np.ndarray:
        """A frame: the car ``footprint`` (4, 2) [m] (at least a few px), camera ``windows``;
        ``race``: a snapshot of several cars, the others drawn and every car named."""
        frame = self.background.copy()
        for corners in windows:
            cv2.polylines(
                frame, [self._pixels(corners)], True, (255, 200, 0), 1, cv2.LINE_AA, _OVERVIEW_BITS
            )
        centre = footprint.mean(axis=0)
        grown = centre + (footprint - centre) * max(1.0, 6.0 / (self.scale * _span(footprint)))
        cv2.fillConvexPoly(frame, self._pixels(grown), (204, 0, 0), cv2.LINE_AA, _OVERVIEW_BITS)
        if race is not None and len(race[0].cars) > 1:
            draw_race(frame, self.matrix, *race, min_size=6.0)
        x = 4
        for image in images:  # camera insets along the top
            h, w = image.shape[:2]
            factor = min(self.size[0] / 4 / w, self.size[1] / 3 / h, 1.0)
            small = cv2.resize(image, (max(int(w * factor), 1), max(int(h * factor), 1)))
            sh, sw = small.shape[:2]
            if x + sw > frame.shape[1] or sh + 4 > frame.shape[0]:
                break
            frame[4 : 4 + sh, x : x + sw] = small
            x += sw + 6
        return np.asarray(frame)

    def _pixels(self, points: np.ndarray) -> np.ndarray:
        return np.round(transform_points(self.matrix, points) * (1 << _OVERVIEW_BITS)).astype(
            np.int32
        )


def _span(points: np.ndarray) -> float:
    return float(np.ptp(points, axis=0).max()) or 1.0
