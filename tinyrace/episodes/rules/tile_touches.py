"""CarRacing's progress: road tiles are sensors; a tile a wheel touches is visited (paid
once, ``tiles``); laps as ``TileProgress``. Wheels on no tile are on the grass
(``off_road``)."""

from __future__ import annotations

from typing import Any

from tinyrace.cars.state import CarState
from tinyrace.episodes.rules.base import (
    OFF_ROAD,
    TILES,
    Info,
    RulePart,
    TileProgress,
    on_grass,
    road_tiles,
)
from tinyrace.tracks.base import Track
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import Contacts, World


class TileTouches(TileProgress):
    """One car's tiles touched and wheels on grass."""

    def __init__(self, track: Track, settings: Any = None) -> None:
        super().__init__(len(road_tiles(track)), track.rules.lap_complete_percent)
        self.wheels_on_grass = 0  # as of the last step

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        self._visit(contacts.new_tile_touches, facts)
        facts.wheels_on_grass = self.wheels_on_grass = on_grass(contacts.wheel_tiles)

    def info(self, info: Info) -> None:
        info["tiles_visited"] = self.visited_count
        info["tiles_total"] = len(self.visited)
        info["wheels_on_grass"] = self.wheels_on_grass  # contacts change only in a step


def furnish(world: World, track: Track) -> None:
    world.add_tiles(road_tiles(track))


PART = RulePart(
    "tile_touches",
    TileTouches,
    furnish,
    terms=(TILES, OFF_ROAD),
    road_tiles=True,
    doc="CarRacing's tiles touched by the wheels",
)
