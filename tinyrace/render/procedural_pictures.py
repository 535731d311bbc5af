"""CarRacing's pictures of a procedural track: the chase view at each render size, the
ground textures it warps (visited tiles repainted), dashboards and car patches."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from tinyrace.config import MAX_TEXTURE_SIDE, EnvConfig, ProceduralTrackConfig
from tinyrace.render.car_sprite import Patches
from tinyrace.render.chase_view import ChaseView
from tinyrace.render.dashboard import Dashboard
from tinyrace.render.pictures import CameraViews
from tinyrace.render.procedural_ground import GroundPainter, repaint_tile
from tinyrace.sensors.draw_cars import CarLooks
from tinyrace.sensors.texture import GroundTexture
from tinyrace.tracks.base import TrackDraw
from tinyrace.tracks.procedural import ProceduralTrack
from tinyrace.tracks.procedural_source import GroundColors, ProceduralSource
from tinyrace.world.snapshot import Snapshot

VIDEO_PIXELS_PER_UNIT = 4.0  # [px/u] ground texture for 600x400 and 1000x800 views
OBSERVATION_SIZE = (96, 96)  # [px] (w, h) CarRacing's state_pixels
SMALL_VIEW = 160  # [px] views up to this size sample the observation texture, supersample the car
RENDER_SIZES = {"state_pixels": OBSERVATION_SIZE, "rgb_array": (600, 400), "human": (1000, 800)}


class ProceduralPictures:
    """CarRacing's views of the current episode; textures and views are made when first asked."""

    def __init__(self, config: EnvConfig, source: ProceduralSource):
        track_config = config.tracks[0]
        assert isinstance(track_config, ProceduralTrackConfig)
        self.track_config = track_config
        self.source = source  # its colours are the current episode's
        self.cache = RenderCache(track_config.playfield)
        self.track: ProceduralTrack | None = None
        self.colors: GroundColors | None = None
        self.visited: Sequence[int] = ()
        self._textures: dict[float, GroundTexture] = {}  # by pixels per unit
        self._painted = 0  # visited tiles repainted on every texture
        self._views: dict[tuple[int, int], ChaseView] = {}
        self.looks = CarLooks.of(config)  # the colours and names of a race's cars

    def reset(self, draw: TrackDraw, visited: Sequence[int]) -> None:
        self.track, self.colors, self.visited = draw.track.detail, self.source.colors, visited
        self._textures, self._views, self._painted = {}, {}, 0

    def observe(self, snapshot: Snapshot, score: float) -> np.ndarray:
        """CarRacing's 96x96 view (the observation when no camera is configured)."""
        return self.chase_view(OBSERVATION_SIZE).render(snapshot, score)

    def frame(
        self, mode: str, snapshot: Snapshot, score: float, cameras: CameraViews = ()
    ) -> np.ndarray:
        """The picture of a render mode: state_pixels 96x96, rgb_array 600x400, human 1000x800."""
        return self.chase_view(RENDER_SIZES[mode]).render(snapshot, score)

    def ground_texture(self) -> GroundTexture:
        """The ground the cameras see, at the track's pixels_per_unit (visited tiles included)."""
        return self.texture(self.track_config.pixels_per_unit)

    def chase_view(self, size: tuple[int, int]) -> ChaseView:
        """CarRacing's view at ``size`` (w, h); small views share the observation texture."""
        if self._painted < len(self.visited):
            self._repaint_visited()
        view = self._views.get(size)
        if view is None:
            small = max(size) <= SMALL_VIEW
            ppu = self.track_config.pixels_per_unit if small else self._video_pixels_per_unit()
            dashboard, patches = self.cache.for_view(size)
            texture = self.texture(ppu)
            view = self._views[size] = ChaseView(size, texture, dashboard, patches, self.looks)
        return view

    def _video_pixels_per_unit(self) -> float:
        """4 px/u for videos, less on huge playfields (the texture stays <= MAX_TEXTURE_SIDE)."""
        return min(VIDEO_PIXELS_PER_UNIT, MAX_TEXTURE_SIDE / (2 * self.track_config.playfield))

    def texture(self, pixels_per_unit: float) -> GroundTexture:
        """The ground at ``pixels_per_unit``, with every tile visited so far repainted."""
        assert self.track is not None and self.colors is not None, "reset() first"
        if self._painted < len(self.visited):
            self._repaint_visited()
        texture = self._textures.get(pixels_per_unit)
        if texture is None:
            texture = self.cache.painter.paint(self.track, self.colors, pixels_per_unit)
            for tile in self.visited[: self._painted]:  # in visit order: the same pixels
                repaint_tile(texture, self.track, tile, self.colors.road)
            self._textures[pixels_per_unit] = texture
        return texture

    def _repaint_visited(self) -> None:
        """Repaint the tiles visited since the last picture on every texture, in visit order."""
        assert self.track is not None and self.colors is not None, "reset() first"
        for tile in self.visited[self._painted :]:
            for texture in self._textures.values():
                repaint_tile(texture, self.track, tile, self.colors.road)
        self._painted = len(self.visited)

    def __getstate__(self) -> dict[str, Any]:
        """Leave out the pictures (tens of MB): they are redrawn from the track when next asked."""
        return {**self.__dict__, "_textures": {}, "_views": {}}


class RenderCache:
    """Pictures that outlive an episode: the ground's background, dashboards, car patches."""

    def __init__(self, playfield: float):
        self.painter = GroundPainter(playfield)
        self._views: dict[tuple[int, int], tuple[Dashboard, Patches]] = {}

    def for_view(self, size: tuple[int, int]) -> tuple[Dashboard, Patches]:
        """The dashboard and the car-patch cache of a view size."""
        if size not in self._views:
            small = max(size) <= SMALL_VIEW
            self._views[size] = (Dashboard(size[0], size[1], supersample=4 if small else 1), {})
        return self._views[size]

    def __getstate__(self) -> dict[str, Any]:
        return {"painter": GroundPainter(self.painter.playfield), "_views": {}}  # cheap to redo
