"""The pictures of an image track: its ground for the cameras, the overview frame."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tinyrace.cars.state import footprint_corners
from tinyrace.config import EnvConfig
from tinyrace.render.overview import Overview
from tinyrace.render.pictures import CameraViews
from tinyrace.sensors.draw_cars import CarLooks
from tinyrace.sensors.texture import GroundTexture
from tinyrace.tracks.base import TrackDraw
from tinyrace.tracks.image import ImageSource, ImageTrack
from tinyrace.world.snapshot import Snapshot


class ImagePictures:
    """Every track's ground texture (made once per env) and overview (when first drawn)."""

    def __init__(self, config: EnvConfig, source: ImageSource):
        self.config = config
        self.tracks: list[ImageTrack] = [layout.detail for layout in source.tracks]
        self.textures = [
            GroundTexture.from_image(track.image, exact_colors=True) for track in self.tracks
        ]
        self.overviews: list[Overview | None] = [None] * len(self.tracks)
        self.index = 0  # the current episode's track
        self.looks = CarLooks.of(config)  # the colours and names of a race's cars

    def reset(self, draw: TrackDraw, visited: Sequence[int]) -> None:
        self.index = draw.track_index

    def observe(self, snapshot: Snapshot, score: float) -> np.ndarray:
        raise ValueError("an image track is seen through its cameras (the config has some)")

    def frame(
        self, mode: str, snapshot: Snapshot, score: float, cameras: CameraViews = ()
    ) -> np.ndarray:
        """state_pixels: the first camera; rgb_array and human: the overview."""
        if mode == "state_pixels":
            return cameras[0][0]
        images = [image for image, _ in cameras]
        windows = [corners for _, corners in cameras]
        race = (snapshot, self.looks)
        return self.overview().render(footprint_corners(snapshot.car), windows, images, race)

    def ground_texture(self) -> GroundTexture:
        """The track picture the cameras see."""
        return self.textures[self.index]

    def overview(self) -> Overview:
        overview = self.overviews[self.index]
        if overview is None:
            cte = self.config.reward_design.cross_track_error
            color = cte.trajectory_color if cte.use_cte else None
            overview = Overview(self.tracks[self.index], self.config.sim.overview_downscale, color)
            self.overviews[self.index] = overview
        return overview
