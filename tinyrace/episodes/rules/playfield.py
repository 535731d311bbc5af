"""The playfield: leaving the track's ``bounds`` (judged at ``rules.bounds_point``) ends the
episode, and that step pays the ``out_of_bounds`` penalty alone (CarRacing's rule)."""

from __future__ import annotations

from typing import Any

from tinyrace.cars.state import CarState
from tinyrace.episodes.rules.base import RuleBase, RulePart
from tinyrace.rewards import Design, End, Term
from tinyrace.tracks.base import Track
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import Contacts


class Playfield(RuleBase):
    """One car's bounds check."""

    def __init__(self, track: Track, settings: Any = None) -> None:
        self.bounds = track.bounds
        self.at_rear_axle = track.rules.bounds_point == "rear_axle"

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        x, y = car.rear_axle if self.at_rear_axle else car.pose[:2]
        x0, y0, x1, y1 = self.bounds
        facts.out_of_bounds = not (x0 <= x <= x1 and y0 <= y <= y1)


def _penalty(facts: StepFacts, design: Design) -> float | None:
    penalty = design.rewards.out_of_bounds_penalty
    return -penalty if penalty else None


def _out(facts: StepFacts, design: Design | None = None) -> bool:
    return facts.out_of_bounds


OUT_OF_BOUNDS = Term("out_of_bounds", _penalty, alone=_out)
PART = RulePart(
    "playfield",
    Playfield,
    terms=(OUT_OF_BOUNDS,),
    ends=(End("out_of_bounds", _out, crash=True),),
    doc="leaving the bounds ends the episode",
)
