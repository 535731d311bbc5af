"""The cross-track error: the rear axle's distance to the track's trajectory [track
units], paid through the ``cte`` shaping (``reward_design.cross_track_error``)."""

from __future__ import annotations

from typing import Any

from tinyrace.cars.state import CarState
from tinyrace.episodes.rules.base import Info, RuleBase, RulePart
from tinyrace.rewards import Design, Term
from tinyrace.tracks.base import Track
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import Contacts


class TrajectoryError(RuleBase):
    """One car's distance to the trajectory."""

    def __init__(self, track: Track, settings: Any = None) -> None:
        self.trajectory = track.trajectory
        self.cte: float | None = None

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        if self.trajectory is not None:
            x, y = car.rear_axle
            self.cte = facts.cte = self.trajectory.query(x, y)[0]

    def info(self, info: Info) -> None:
        if self.cte is not None:
            info["cte"] = self.cte  # [track units]


def _cte_pay(facts: StepFacts, design: Design) -> float | None:
    shaping = design.shaping
    if shaping is not None and facts.cte is not None:
        return float(shaping(facts.cte))
    return None


# ``cte``: the shaping of the cross-track error
def _shaped(design: Design) -> bool:
    return design.shaping is not None


CTE = Term("cte", _cte_pay, _shaped)
PART = RulePart("trajectory_error", TrajectoryError, terms=(CTE,), doc="distance to a trajectory")
