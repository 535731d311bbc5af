"""Grass: wheels off the road tiles grip as on grass, and pay ``off_road`` (a car with
wheels on a road read from a file)."""

from __future__ import annotations

from typing import Any

from tinyrace.cars.state import CarState
from tinyrace.episodes.rules.base import OFF_ROAD, RuleBase, RulePart, on_grass, road_tiles
from tinyrace.tracks.base import Track
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import Contacts, World


class Grass(RuleBase):
    """One car's wheels on grass."""

    def __init__(self, track: Track, settings: Any = None) -> None:
        pass

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        facts.wheels_on_grass = on_grass(contacts.wheel_tiles)


def furnish(world: World, track: Track) -> None:
    world.add_tiles(road_tiles(track))


PART = RulePart(
    "grass",
    Grass,
    furnish,
    terms=(OFF_ROAD,),
    wheels_only=True,
    road_tiles=True,
    doc="wheels off the road grip as on grass",
)
