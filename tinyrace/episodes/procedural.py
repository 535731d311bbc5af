"""An episode on CarRacing's procedural track: tiles to visit, a lap to finish, a playfield."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from tinyrace.cars.registry import CarModel
from tinyrace.config import EnvConfig, ProceduralTrackConfig
from tinyrace.tracks.base import TrackDraw
from tinyrace.tracks.procedural import ProceduralTrack
from tinyrace.tracks.procedural_source import ProceduralSource
from tinyrace.world.facts import StepFacts
from tinyrace.world.snapshot import Snapshot
from tinyrace.world.world import World


class ProceduralEpisode:
    """One reset of the procedural track: its world (tiles, car) and the tiles visited."""

    def __init__(self, config: EnvConfig, draw: TrackDraw, car_model: CarModel):
        self.config = config
        track_config = config.tracks[0]
        assert isinstance(track_config, ProceduralTrackConfig)
        self.track_config = track_config
        self.layout = draw.track  # the generic view (tinyrace.tracks.base.Track)
        self.track: ProceduralTrack = draw.track.detail
        self.world = World(grass_off_tiles=True)
        self.world.add_tiles(self.track.tiles)
        self.world.add_car(car_model.build(self.world.space, draw.spawn, config.car, draw.track))
        self.visited = np.zeros(len(self.track.tiles), bool)
        self.visited_count = 0
        self.visit_order: list[int] = []  # tiles in the order first visited (pictures repaint)
        self.wheels_on_grass = _on_grass(self.world.contacts[0].wheel_tiles)  # as of the last step

    def start(self, dt: float) -> StepFacts:
        """CarRacing's reset takes one physics step with no action."""
        return self.step(dt)

    def step(self, dt: float) -> StepFacts:
        """The world's step with the controls the cars hold; the rules' facts."""
        self.world.apply_forces(dt)
        return self.advance(dt)

    def advance(self, dt: float) -> StepFacts:
        """The rest of a step whose forces are set: the world advanced, the rules' facts."""
        contacts = self.world.advance(dt)[0]
        facts = self._visit(contacts.new_tile_touches)
        facts.wheels_on_grass = self.wheels_on_grass = _on_grass(contacts.wheel_tiles)
        x, y, _ = self.world.states()[0].pose
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
            fraction = self.visited_count / len(self.visited)
            if tile == 0 and fraction > self.track_config.lap_complete_percent:
                facts.lap_finished = True
        if self.visited_count == len(self.visited):
            facts.lap_finished = True
        return facts

    def info(self, snapshot: Snapshot) -> dict[str, Any]:
        car = snapshot.car
        return {
            "pose": car.pose,
            "speed": car.speed,
            "tiles_visited": self.visited_count,
            "tiles_total": len(self.visited),
            "wheels_on_grass": self.wheels_on_grass,  # contacts change only in a step
        }


def _on_grass(wheel_tiles: Sequence[set[int]]) -> int:
    """How many wheels touch no road tile."""
    return len(wheel_tiles) - sum(map(bool, wheel_tiles))


class ProceduralCourse:
    """What lasts across resets on a procedural track: the source (it draws each track)."""

    def __init__(self, config: EnvConfig, source: ProceduralSource, car_model: CarModel):
        self.config = config
        self.source = source
        self.car_model = car_model

    def new_episode(self, draw: TrackDraw) -> ProceduralEpisode:
        return ProceduralEpisode(self.config, draw, self.car_model)
