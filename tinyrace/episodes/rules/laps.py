"""The race's laps: the episode ends when a car finishes its last lap (``race.laps``; the
episode counts the laps, a progress part says when one is finished), in every episode."""

from __future__ import annotations

from tinyrace.episodes.rules.base import RulePart
from tinyrace.rewards import Design, End
from tinyrace.world.facts import StepFacts


def _finished(facts: StepFacts, design: Design) -> bool:
    return facts.lap_finished


LAP_FINISHED = End("lap_finished", _finished)
PART = RulePart("laps", None, ends=(LAP_FINISHED,), always=True, doc="the last lap ends it")
