"""What a rule part is: its registry entry (``RulePart``), the ``Rule`` one car's instance
satisfies, and the tile progress several parts share.

A rule part is one module: a ``RulePart`` naming its class (one instance per car, made
for each episode), what it puts into the world once per track (``furnish``), the reward
terms it can pay and the end reasons it can give (``tinyrace.rewards.Term`` / ``End``),
and, when it has knobs, its config dataclass (a ``rules:`` entry of its ``type``). After
every step the instance reads its car's contacts and state and writes its findings into
the car's ``StepFacts`` (a built-in field, or ``facts.more[<name>]`` for a part's own).
Parts never touch the pymunk space, and nothing here asks which kind of track it is.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from tinyrace.cars.state import CarState
from tinyrace.rewards import Design, End, Term
from tinyrace.tracks.base import Track
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import Contacts, World

Info = dict[str, Any]


class Rule(Protocol):
    """One rule part of an episode, for one car."""

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        """Read the car's contacts and state after a step; write the findings into ``facts``."""

    def info(self, info: Info) -> None:
        """Add this rule's keys to the car's info (as of the last step)."""

    def new_lap(self) -> None:
        """A lap was finished and the race goes on (tiles to visit again, a gate anew)."""

    def tile_progress(self) -> TileProgress | None:
        """The tiles this rule counts as visited (pictures and race positions read them),
        or None for a rule that counts no tiles."""


class RuleBase:
    """A rule that does nothing yet: subclass it and override what the part does."""

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        pass

    def info(self, info: Info) -> None:
        pass

    def new_lap(self) -> None:
        pass

    def tile_progress(self) -> TileProgress | None:
        return None


def nothing_to_furnish(world: World, track: Track) -> None:
    """A part that puts nothing into the world (it reads the car's state only)."""


@dataclass(frozen=True)
class RulePart:
    """A rule part's registry entry (``tinyrace.episodes.rules.register``).

    ``make(track, settings)`` is one car's ``Rule`` for an episode on ``track``
    (``settings``: the part's ``rules:`` entry, or None), or None for a part with no state
    per car (its terms and ends read the facts alone). ``config``: its ``rules:`` entry's
    dataclass (a ``type`` field whose default is ``name``), if it has knobs; a configured
    entry adds the part to every car's episode. ``always``: in every episode whatever the
    track lists (the clock's time cost, the end of the race's last lap).
    ``wheels_only``: only for cars that model wheels; ``road_tiles``: its tiles are the
    wheels' road (off them a wheel grips as on grass). ``needs``: what its track must hold
    (a ``TrackFacts.holds`` entry, as a sensor type's), checked where a ``rules:`` entry
    adds it."""

    name: str
    make: Callable[[Track, Any], Rule] | None
    furnish: Callable[[World, Track], None] = nothing_to_furnish
    terms: tuple[Term, ...] = ()
    ends: tuple[End, ...] = ()
    config: type | None = None
    always: bool = False
    wheels_only: bool = False
    road_tiles: bool = False
    needs: str | None = None
    doc: str = ""


class TileProgress(RuleBase):
    """Tiles visited once each, in the order first visited, and the lap rule: a lap ends
    when every tile is visited, or back on tile 0 after ``lap_complete_percent`` of them."""

    def __init__(self, tiles: int, lap_percent: float) -> None:
        self.visited = np.zeros(tiles, bool)
        self.visited_count = 0
        self.visit_order: list[int] = []  # tiles in the order first visited (pictures repaint)
        self.lap_percent = lap_percent

    def tile_progress(self) -> TileProgress:
        return self

    def new_lap(self) -> None:
        """Every tile to visit again (a race of several laps goes on after a lap)."""
        self.visited[:] = False
        self.visited_count = 0

    def _visit(self, tiles: Sequence[int], facts: StepFacts) -> None:
        """Mark ``tiles`` (reached in this order during the step) visited; the lap rule."""
        n = len(self.visited)
        facts.tiles_total = n
        for tile in tiles:
            if not self.visited[tile]:
                self.visited[tile] = True
                self.visited_count += 1
                self.visit_order.append(tile)
                facts.tiles.append(tile)
                facts.new_tiles += 1
            if tile == 0 and self.visited_count / n > self.lap_percent:
                facts.lap_finished = True
        if self.visited_count == n:
            facts.lap_finished = True


def _tiles_pay(facts: StepFacts, design: Design) -> float | None:
    progress = design.rewards.tile_progress
    if facts.new_tiles and progress:
        return progress * facts.new_tiles / facts.tiles_total
    return None


# ``tiles``: tile_progress shared out over the tiles, paid per newly visited tile; the
# tiles the reset's step touched are paid by the first step (as CarRacing does)
def _tiles_paid(design: Design) -> bool:
    return bool(design.rewards.tile_progress)


TILES = Term("tiles", _tiles_pay, _tiles_paid, carried=True)


def _off_road_pay(facts: StepFacts, design: Design) -> float | None:
    penalty = design.rewards.off_road_penalty
    if facts.wheels_on_grass and penalty:
        return -penalty * facts.wheels_on_grass
    return None


# ``off_road``: the penalty per wheel on grass
def _off_road_charged(design: Design) -> bool:
    return bool(design.rewards.off_road_penalty)


OFF_ROAD = Term("off_road", _off_road_pay, _off_road_charged)


def road_tiles(track: Track) -> np.ndarray:
    """The track's tiles (a track lists a tile rule only when it has tiles)."""
    assert track.tiles is not None
    return track.tiles


def on_grass(wheel_tiles: Sequence[set[int]]) -> int:
    """How many wheels touch no road tile."""
    return len(wheel_tiles) - sum(map(bool, wheel_tiles))
