"""How an env's steps are judged, made once per env: the design the rule parts' terms and
ends read, each car's terms and ends by its parts, and the step limit.

The ``Episode`` owns the clock, the step counter, the scores and the carried rewards, and
asks its referee for each car's ``CarStep`` after the rules found the facts.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

from tinyrace.config import EnvConfig
from tinyrace.episodes.rules import rule_type
from tinyrace.rewards import (
    CteShaping,
    Design,
    Judging,
    end_of,
    judging,
    reward_terms,
    shaping_from_config,
)
from tinyrace.world.facts import StepFacts


class CarStep(NamedTuple):
    """One car's step, judged: its reward terms and their sum, why its episode ends (or
    None) and whether the step limit truncates it."""

    terms: dict[str, float]
    reward: float
    reason: str | None
    truncated: bool


class Referee:
    """The rewards and ends of every step of an env (``config``'s ``reward_design`` and
    ``rules:`` entries; ``shaping`` for the cross-track error, else the design's own)."""

    def __init__(self, config: EnvConfig, shaping: CteShaping | None = None) -> None:
        if shaping is None:
            shaping = shaping_from_config(config.reward_design)
        settings = {entry.type: entry for entry in config.rules}
        self.design = Design(config.reward_design, shaping, settings)
        self.limit = config.sim.step_limit  # [steps] or None
        fps = config.sim.fps
        assert fps is not None  # resolved by the config loader
        self.dt = 1.0 / fps  # [s]
        self._judging: dict[tuple[str, ...], Judging] = {}

    def parts(self, parts: Sequence[str]) -> Judging:
        """The terms and ends of a car with rule parts ``parts`` (and every ``always`` part)."""
        key = tuple(parts)
        found = self._judging.get(key)
        if found is None:
            entries = [rule_type(name) for name in key]
            terms = [term.name for part in entries for term in part.terms]
            ends = [end.reason for part in entries for end in part.ends]
            found = self._judging[key] = judging(terms, ends, self.design)
        return found

    def carried(self, facts: StepFacts, judge: Judging) -> dict[str, float]:
        """The terms of a reset's step (not rewarded) that the first step pays."""
        terms, alone = reward_terms(facts, self.design, judge.carried, judge.alone)
        return {} if alone else terms

    def judge(
        self, facts: StepFacts, judge: Judging, carried: dict[str, float], steps: int
    ) -> tuple[CarStep, bool]:
        """One car's step after ``steps`` steps, paying ``carried`` too; and whether the
        step counts in the car's running score (not when a term paid alone)."""
        design = self.design
        terms, alone = reward_terms(facts, design, judge.terms, judge.alone)
        if carried:
            both = {**terms, **carried}
            terms = {key: terms.get(key, 0.0) + carried.get(key, 0.0) for key in both}
        reward = float(sum(terms.values()))
        reason = end_of(facts, design, judge.ends)
        limit = self.limit
        truncated = reason is None and limit is not None and steps >= limit
        return CarStep(terms, reward, reason, truncated), not alone
