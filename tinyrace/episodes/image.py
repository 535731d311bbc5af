"""Episodes on image tracks: obstacle colours under the footprint, distance to a trajectory."""

from __future__ import annotations

from typing import Any

from tinyrace.cars.registry import CarModel
from tinyrace.cars.state import footprint_corners
from tinyrace.config import EnvConfig
from tinyrace.tracks.base import TrackDraw
from tinyrace.tracks.image import ImageSource, ImageTrack, ObstaclePixels
from tinyrace.world.facts import StepFacts
from tinyrace.world.snapshot import Snapshot
from tinyrace.world.world import World


class ImageEpisode:
    """One reset on an image track: the chosen track and spawn, a car in its world."""

    def __init__(
        self,
        config: EnvConfig,
        world: World,
        draw: TrackDraw,
        car_model: CarModel,
        pixels: ObstaclePixels,
    ):
        self.config = config
        self.layout = draw.track  # the generic view (tinyrace.tracks.base.Track)
        self.track: ImageTrack = draw.track.detail
        self.track_index, self.spawn_index = draw.track_index, draw.spawn_index
        self.world = world
        self.pixels = pixels  # the track's obstacle pixels, for the footprint test
        self.world.remove_cars()  # the last episode's car; the obstacle sensors stay
        self.world.add_car(car_model.build(self.world.space, draw.spawn, config.car, draw.track))
        self.visit_order: list[int] = []  # an image track has no tiles
        self.obstacles_hit: list[int] = []
        self.cte: float | None = None
        width, height = self.track.size
        self._inside = (-0.5, width - 0.5, -0.5, height - 0.5)  # [px] x, y bounds of the image
        self._color_names = [repr(color) for color in self.track.obstacle_colors]  # "#rrggbb"

    def start(self, dt: float) -> StepFacts:
        """The reset's look at the spawn: tinycarlo's reset neither moves the car nor rewards
        anything, so the car stays put (pymunk still reports its contacts) and the facts
        are for info only."""
        self.world.look(dt)
        self._judge()
        return StepFacts()

    def step(self, dt: float) -> StepFacts:
        """The world's step with the controls the cars hold; the rules' facts."""
        self.world.apply_forces(dt)
        return self.advance(dt)

    def advance(self, dt: float) -> StepFacts:
        """The rest of a step whose forces are set: the world advanced (full grip: no grass
        here), the rules' facts."""
        self.world.advance(dt)
        return self._judge()

    def _judge(self) -> StepFacts:
        """Obstacle colours under the footprint, the cte, the image's bounds."""
        contacts, car = self.world.contacts[0], self.world.states()[0]
        facts = StepFacts()
        if contacts.obstacle_cells:
            corners = footprint_corners(car)
            facts.obstacles_hit = self.pixels.touched(corners, contacts.obstacle_cells)
        x, y = car.rear_axle
        if self.track.trajectory is not None:
            facts.cte = self.track.trajectory.query(x, y)[0]
        left, right, top, bottom = self._inside
        facts.out_of_bounds = not (left <= x < right and top <= y < bottom)
        self.obstacles_hit, self.cte = facts.obstacles_hit, facts.cte
        return facts

    def info(self, snapshot: Snapshot) -> dict[str, Any]:
        car = snapshot.car
        names = self._color_names
        info = {
            "pose": car.pose,
            "speed": car.speed,
            "track": self.track_index,
            "spawn": self.spawn_index,
            "obstacles_hit": [names[i] for i in self.obstacles_hit],  # "#rrggbb" each
        }
        if self.cte is not None:
            info["cte"] = self.cte  # [px]
        return info


class ImageCourse:
    """What lasts across resets: one world per track, its obstacle sensors built once, and
    each track's obstacle pixels."""

    def __init__(self, config: EnvConfig, source: ImageSource, car_model: CarModel):
        self.config = config
        self.source = source
        self.car_model = car_model
        self.worlds: list[World] = []
        self.pixels = [ObstaclePixels(layout.detail) for layout in source.tracks]
        for layout in source.tracks:
            world = World()
            world.add_obstacle_cells(layout.detail.cells)
            self.worlds.append(world)

    @property
    def tracks(self) -> list[ImageTrack]:
        return [layout.detail for layout in self.source.tracks]

    def new_episode(self, draw: TrackDraw) -> ImageEpisode:
        index = draw.track_index
        return ImageEpisode(
            self.config, self.worlds[index], draw, self.car_model, self.pixels[index]
        )
