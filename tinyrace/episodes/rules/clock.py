"""The clock: every step costs ``reward_design.time_penalty`` (the ``time`` term), in every
episode."""

from __future__ import annotations

from tinyrace.episodes.rules.base import RulePart
from tinyrace.rewards import Design, Term
from tinyrace.world.facts import StepFacts


def _time_pay(facts: StepFacts, design: Design) -> float | None:
    penalty = design.rewards.time_penalty
    return -penalty if penalty else None


def _charged(design: Design) -> bool:
    return bool(design.rewards.time_penalty)


TIME = Term("time", _time_pay, _charged)
PART = RulePart("clock", None, terms=(TIME,), always=True, doc="the per-step time cost")
