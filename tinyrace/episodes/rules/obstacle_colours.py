"""tinycarlo's obstacles: the obstacle colours whose pixels lie under the footprint pay
their ``reward_design.color_obstacles`` reward (``obstacles``), or end the episode
(``done``: the ``obstacle`` end)."""

from __future__ import annotations

from typing import Any

from tinyrace.cars.state import CarState, footprint_corners
from tinyrace.episodes.rules.base import Info, RuleBase, RulePart
from tinyrace.rewards import Design, End, Term
from tinyrace.tracks.base import Track
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import Contacts, World


class ObstacleColours(RuleBase):
    """One car's obstacle colours touched."""

    def __init__(self, track: Track, settings: Any = None) -> None:
        self.test = track.obstacle_test
        self.names = [repr(layer.color) for layer in track.obstacles]  # "#rrggbb" each
        self.hit: list[int] = []

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        if contacts.obstacle_cells and self.test is not None:
            facts.obstacles_hit = self.test.touched(footprint_corners(car), contacts.obstacle_cells)
        self.hit = facts.obstacles_hit

    def info(self, info: Info) -> None:
        info["obstacles_hit"] = [self.names[i] for i in self.hit]


def furnish(world: World, track: Track) -> None:
    test = track.obstacle_test
    if test is not None:
        world.add_obstacle_cells(test.cells)


def _obstacles_pay(facts: StepFacts, design: Design) -> float | None:
    obstacles = design.rewards.color_obstacles
    total = sum(reward for i in facts.obstacles_hit if (reward := obstacles[i].reward) != "done")
    return float(total) if total else None


def _pays(design: Design) -> bool:
    return any(o.reward != "done" and o.reward for o in design.rewards.color_obstacles)


def _done(facts: StepFacts, design: Design) -> bool:
    obstacles = design.rewards.color_obstacles
    return bool(facts.obstacles_hit) and any(
        obstacles[i].reward == "done" for i in facts.obstacles_hit
    )


PART = RulePart(
    "obstacle_colours",
    ObstacleColours,
    furnish,
    terms=(Term("obstacles", _obstacles_pay, _pays),),
    ends=(End("obstacle", _done, crash=True),),
    doc="obstacle colours under the footprint",
)
