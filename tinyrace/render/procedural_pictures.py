"""CarRacing's pictures of a procedural track: the chase view at each render size, on the
episode's ground (``tinyrace.ground.grounds``) at the size's resolution."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from tinyrace.config import MAX_TEXTURE_SIDE
from tinyrace.ground.grounds import Rescalable
from tinyrace.render.pictures import CameraViews
from tinyrace.sensors.chase_view import SMALL_VIEW, ChaseView, small_dashboard
from tinyrace.sensors.machinery.dashboard import Dashboard
from tinyrace.sensors.machinery.draw_cars import CarLooks
from tinyrace.tracks.base import TrackDraw
from tinyrace.world.snapshot import Snapshot

VIDEO_PIXELS_PER_UNIT = 4.0  # [px/u] ground texture for 600x400 and 1000x800 views
OBSERVATION_SIZE = (96, 96)  # [px] (w, h) CarRacing's state_pixels
RENDER_SIZES = {"state_pixels": OBSERVATION_SIZE, "rgb_array": (600, 400), "human": (1000, 800)}


class ProceduralPictures:
    """CarRacing's views of the current episode; views are made when first asked."""

    def __init__(self, ground: Rescalable, looks: CarLooks | None = None):
        self.painted = ground.painted  # the playfield and the cameras' pixels_per_unit
        self.ground = ground
        self._cache: dict[tuple[int, int], Dashboard] = {}  # across episodes
        self._views: dict[tuple[int, int], ChaseView] = {}
        self.looks = looks  # the colours and names of a race's cars

    def reset(self, draw: TrackDraw) -> None:
        self._views = {}

    def frame(self, mode: str, snapshot: Snapshot, cameras: CameraViews = ()) -> np.ndarray:
        """The picture of a render mode: state_pixels 96x96, rgb_array 600x400, human 1000x800."""
        return self.chase_view(RENDER_SIZES[mode]).render(snapshot, snapshot.score)

    def chase_view(self, size: tuple[int, int]) -> ChaseView:
        """CarRacing's view at ``size`` (w, h); small views share the observation texture."""
        small = max(size) <= SMALL_VIEW
        ppu = self.painted.pixels_per_unit if small else self._video_pixels_per_unit()
        texture = self.ground.texture_at(ppu)  # asked each frame: visited tiles get repainted
        view = self._views.get(size)
        if view is None or view.texture is not texture:
            dashboard = self._cache.get(size)
            if dashboard is None:
                dashboard = self._cache[size] = small_dashboard(size)
            view = self._views[size] = ChaseView(size, texture, dashboard, self.looks)
        return view

    def _video_pixels_per_unit(self) -> float:
        """4 px/u for videos, less on huge playfields (the texture stays <= MAX_TEXTURE_SIDE)."""
        return min(VIDEO_PIXELS_PER_UNIT, MAX_TEXTURE_SIDE / (2 * self.painted.playfield))

    def __getstate__(self) -> dict[str, Any]:
        """Leave out the pictures: they are redrawn when next asked."""
        return {**self.__dict__, "_cache": {}, "_views": {}}

    def name_insets(
        self, frame: np.ndarray, names: Sequence[str], sizes: Sequence[tuple[int, ...]]
    ) -> None:
        """This picture insets no camera image: nothing to name."""
