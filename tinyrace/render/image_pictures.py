"""The pictures of tracks that carry a picture: the overview frame (their ground is it)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tinyrace.cars.state import footprint_corners
from tinyrace.config import EnvConfig
from tinyrace.ground.grounds import EpisodeGround
from tinyrace.render.overview import Overview
from tinyrace.render.pictures import CameraViews
from tinyrace.sensors.machinery.draw_cars import CarLooks
from tinyrace.tracks.base import Track, TrackDraw
from tinyrace.world.snapshot import Snapshot


class ImagePictures:
    """Every track's overview (made when first drawn)."""

    def __init__(self, config: EnvConfig, ground: EpisodeGround):
        self.config = config
        self.tracks: Sequence[Track] = ground.tracks
        self.overviews: list[Overview | None] = [None] * len(self.tracks)
        self.index = 0  # the current episode's track
        self.looks = CarLooks.of(config)  # the colours and names of a race's cars

    def reset(self, draw: TrackDraw) -> None:
        self.index = draw.track_index

    def frame(self, mode: str, snapshot: Snapshot, cameras: CameraViews = ()) -> np.ndarray:
        """state_pixels: the first camera; rgb_array and human: the overview."""
        if mode == "state_pixels":
            return cameras[0][0]
        images = [image for image, _ in cameras]
        windows = [corners for _, corners in cameras if corners is not None]
        race = (snapshot, self.looks)
        return self.overview().render(footprint_corners(snapshot.car), windows, images, race)

    def overview(self) -> Overview:
        overview = self.overviews[self.index]
        if overview is None:
            cte = self.config.reward_design.cross_track_error
            color = cte.trajectory_color if cte.use_cte else None
            overview = Overview(self.tracks[self.index], self.config.sim.overview_downscale, color)
            self.overviews[self.index] = overview
        return overview
