"""Walls and cones: walls stop the car (the world puts it back; ``walls`` per step,
optionally the end), cones are knocked over once each (``cones`` per cone, optionally the
end): the ``collision`` end, as the track's ``TrackRules`` say."""

from __future__ import annotations

from typing import Any

from tinyrace.cars.state import CarState
from tinyrace.episodes.rules.base import Info, RuleBase, RulePart
from tinyrace.rewards import Design, End, Term
from tinyrace.tracks.base import Track
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import Contacts, World


class Collisions(RuleBase):
    """One car's walls touched and cones knocked over."""

    def __init__(self, track: Track, settings: Any = None) -> None:
        self.wall_ends, self.cone_ends = track.rules.wall_hit_ends, track.rules.cone_hit_ends
        self.knocked: set[int] = set()
        self.walls_hit = 0

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        if contacts.crashed:
            facts.wall_hit = True
            self.walls_hit += 1
            facts.collision_ends = self.wall_ends
        new_cones = contacts.cones - self.knocked
        if new_cones:
            self.knocked |= new_cones
            facts.cones_hit = len(new_cones)
            facts.collision_ends |= self.cone_ends

    def info(self, info: Info) -> None:
        info["cones_hit"] = len(self.knocked)
        info["walls_hit"] = self.walls_hit


def furnish(world: World, track: Track) -> None:
    world.add_cones(track.cones[:, :2], track.cone_radii)
    world.add_walls(track.walls)


def _cones_pay(facts: StepFacts, design: Design) -> float | None:
    penalty = design.rewards.cone_penalty
    return -penalty * facts.cones_hit if facts.cones_hit and penalty else None


def _walls_pay(facts: StepFacts, design: Design) -> float | None:
    penalty = design.rewards.wall_penalty
    return -penalty if facts.wall_hit and penalty else None


def _cones_charged(design: Design) -> bool:
    return bool(design.rewards.cone_penalty)


def _walls_charged(design: Design) -> bool:
    return bool(design.rewards.wall_penalty)


def _ends(facts: StepFacts, design: Design) -> bool:
    return facts.collision_ends


PART = RulePart(
    "collisions",
    Collisions,
    furnish,
    terms=(
        Term("cones", _cones_pay, _cones_charged),
        Term("walls", _walls_pay, _walls_charged),
    ),
    ends=(End("collision", _ends, crash=True),),
    doc="walls stop the car, cones are knocked over",
)
