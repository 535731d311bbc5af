"""An episode on CarRacing's procedural track: tiles to visit, a lap to finish, a playfield."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from tinyrace.cars.dynamic import DynamicCar
from tinyrace.cars.registry import CarModel
from tinyrace.config import MAX_TEXTURE_SIDE, EnvConfig, ProceduralTrackConfig
from tinyrace.render.car_sprite import Patches
from tinyrace.render.chase_view import ChaseView
from tinyrace.render.dashboard import Dashboard
from tinyrace.render.procedural_ground import GroundPainter, repaint_tile
from tinyrace.render.texture import GroundTexture
from tinyrace.tracks.base import TrackDraw
from tinyrace.tracks.procedural import ProceduralTrack
from tinyrace.tracks.procedural_source import GroundColors, ProceduralSource
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import World

CameraViews = Sequence[tuple[np.ndarray, np.ndarray]]  # per camera: (image, window corners)
VIDEO_PIXELS_PER_UNIT = 4.0  # [px/u] ground texture for 600x400 and 1000x800 views
OBSERVATION_SIZE = (96, 96)  # [px] (w, h) CarRacing's state_pixels
SMALL_VIEW = 160  # [px] views up to this size sample the observation texture, supersample the car
RENDER_SIZES = {"state_pixels": OBSERVATION_SIZE, "rgb_array": (600, 400), "human": (1000, 800)}


class ProceduralEpisode:
    """One reset of the procedural track: track, pymunk world, car, visited tiles."""

    def __init__(
        self,
        config: EnvConfig,
        draw: TrackDraw,
        car_model: CarModel,
        colors: GroundColors,
        cache: RenderCache | None = None,
    ):
        self.config = config
        track_config = config.tracks[0]
        assert isinstance(track_config, ProceduralTrackConfig)
        self.track_config = track_config
        self.cache = cache or RenderCache(track_config.playfield)
        self.layout = draw.track  # the generic view (tinyrace.tracks.base.Track)
        self.track: ProceduralTrack = draw.track.detail
        self.colors = colors
        self.world = World()
        self.world.add_tiles(self.track.tiles)
        car = car_model.build(self.world.space, draw.spawn, config.car, draw.track)
        assert isinstance(car, DynamicCar)  # the cars registry allows no other here
        self.car = car
        self.visited = np.zeros(len(self.track.tiles), bool)
        self.visited_count = 0
        self.visit_order: list[int] = []  # repainting in this order redraws the same pixels
        self._textures: dict[float, GroundTexture] = {}
        self._views: dict[tuple[int, int], ChaseView] = {}

    # -- physics and facts -------------------------------------------------------------------
    def start(self, dt: float) -> StepFacts:
        """CarRacing's reset takes one physics step with no action."""
        return self.step(dt)

    def step(self, dt: float) -> StepFacts:
        self.car.apply_forces(dt, self.wheels_on_road())
        return self.advance(dt)

    def wheels_on_road(self) -> list[bool]:
        """Per wheel: does it touch a road tile now (else it is on grass)."""
        return [bool(tiles) for tiles in self.world.contacts.wheel_tiles]

    def advance(self, dt: float) -> StepFacts:
        """The world's step once the car's forces are applied; the facts it produced."""
        contacts = self.world.contacts
        self.world.step(dt)
        facts = self._visit(contacts.new_tile_touches)
        facts.wheels_on_grass = sum(not tiles for tiles in contacts.wheel_tiles)
        x, y = self.car.body.position
        facts.out_of_bounds = max(abs(x), abs(y)) > self.track_config.playfield
        return facts

    def _visit(self, touched: Sequence[int]) -> StepFacts:
        """Mark newly touched tiles; a lap ends on all tiles, or back on tile 0 after enough."""
        facts = StepFacts(tiles_total=len(self.visited))
        for tile in touched:
            if not self.visited[tile]:
                self.visited[tile] = True
                self.visited_count += 1
                self.visit_order.append(tile)
                facts.new_tiles += 1
                for texture in self._textures.values():
                    repaint_tile(texture, self.track, tile, self.colors.road)
            fraction = self.visited_count / len(self.visited)
            if tile == 0 and fraction > self.track_config.lap_complete_percent:
                facts.lap_finished = True
        if self.visited_count == len(self.visited):
            facts.lap_finished = True
        return facts

    def info(self) -> dict[str, Any]:
        x, y, heading = self.car.pose
        return {
            "pose": (x, y, heading),
            "speed": self.car.speed,
            "tiles_visited": self.visited_count,
            "tiles_total": len(self.visited),
            "wheels_on_grass": sum(not tiles for tiles in self.world.contacts.wheel_tiles),
        }

    # -- pictures ----------------------------------------------------------------------------
    def observe(self, t: float, score: float) -> np.ndarray:
        """CarRacing's 96x96 view (the observation when no camera is configured)."""
        return self.chase_view(OBSERVATION_SIZE).render(t, score)

    def frame(self, mode: str, t: float, score: float, cameras: CameraViews = ()) -> np.ndarray:
        """The picture of a render mode: state_pixels 96x96, rgb_array 600x400, human 1000x800."""
        return self.chase_view(RENDER_SIZES[mode]).render(t, score)

    def ground_texture(self) -> GroundTexture:
        """The ground the cameras see, at the track's pixels_per_unit (visited tiles included)."""
        return self.texture(self.track_config.pixels_per_unit)

    def chase_view(self, size: tuple[int, int]) -> ChaseView:
        """CarRacing's view at ``size`` (w, h); small views share the observation texture."""
        view = self._views.get(size)
        if view is None:
            small = max(size) <= SMALL_VIEW
            ppu = self.track_config.pixels_per_unit if small else self._video_pixels_per_unit()
            dashboard, patches = self.cache.for_view(size)
            view = ChaseView(size, self.texture(ppu), self.car, dashboard, patches)
            self._views[size] = view
        return view

    def _video_pixels_per_unit(self) -> float:
        """4 px/u for videos, less on huge playfields (the texture stays <= MAX_TEXTURE_SIDE)."""
        return min(VIDEO_PIXELS_PER_UNIT, MAX_TEXTURE_SIDE / (2 * self.track_config.playfield))

    def texture(self, pixels_per_unit: float) -> GroundTexture:
        texture = self._textures.get(pixels_per_unit)
        if texture is None:
            texture = self.cache.painter.paint(self.track, self.colors, pixels_per_unit)
            self._repaint_visited(texture)
            self._textures[pixels_per_unit] = texture
        return texture

    def _repaint_visited(self, texture: GroundTexture) -> None:
        for tile in self.visit_order:
            repaint_tile(texture, self.track, tile, self.colors.road)

    # -- pickling ----------------------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        """Leave out the pictures (tens of MB): they are redrawn from the track when next asked."""
        state = self.__dict__.copy()
        state.update(_textures={}, _views={})
        return state


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


class ProceduralCourse:
    """What lasts across resets on a procedural track: the source and the picture caches."""

    def __init__(self, config: EnvConfig, source: ProceduralSource, car_model: CarModel):
        self.config = config
        self.source = source
        self.car_model = car_model
        self.cache = RenderCache(source.config.playfield)

    @property
    def colors(self) -> GroundColors:
        """The colours of the last episode."""
        return self.source.colors

    def new_episode(self, draw: TrackDraw) -> ProceduralEpisode:
        return ProceduralEpisode(self.config, draw, self.car_model, self.colors, self.cache)
