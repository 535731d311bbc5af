"""Rewards are decided here, and only here, from the facts of a step.

Each term is named; the step's reward is their sum and the terms are reported
in ``info["reward_terms"]`` so that a reward design can be inspected. A term is a
function of the step's facts and the ``reward_design`` (the ``RewardTerm`` protocol);
adding one is a function here plus an entry in ``REWARD_TERMS``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Protocol

from tinyrace.config import RewardConfig
from tinyrace.world.facts import StepFacts

CteShaping = Callable[[float], float]


@dataclass(frozen=True)
class Shaping:
    """A common cross-track-error shaping chosen in YAML (picklable, unlike a lambda)."""

    kind: str  # linear, quadratic, exponential or gaussian
    scale: float  # [track units]
    weight: float

    def __call__(self, error: float) -> float:
        e = error / self.scale
        if self.kind == "linear":
            return -self.weight * e
        if self.kind == "quadratic":
            return -self.weight * e * e
        if self.kind == "exponential":
            return self.weight * math.exp(-e)
        return self.weight * math.exp(-0.5 * e * e)


def shaping_from_config(config: RewardConfig) -> CteShaping | None:
    """The YAML's choice of cross-track-error shaping, or None for no cte reward."""
    cte = config.cross_track_error
    return None if cte.shaping == "none" else Shaping(cte.shaping, cte.scale, cte.weight)


class RewardTerm(Protocol):
    """One named reward term: its value for a step's facts, or None when it does not apply."""

    def __call__(
        self, facts: StepFacts, config: RewardConfig, shaping: CteShaping | None
    ) -> float | None: ...


def time_term(facts: StepFacts, config: RewardConfig, shaping: CteShaping | None) -> float | None:
    """``time``: the per-step cost."""
    return -config.time_penalty if config.time_penalty else None


def tiles_term(facts: StepFacts, config: RewardConfig, shaping: CteShaping | None) -> float | None:
    """``tiles``: tile_progress shared out over the tiles, paid per newly visited tile."""
    if facts.new_tiles and config.tile_progress:
        return config.tile_progress * facts.new_tiles / facts.tiles_total
    return None


def off_road_term(
    facts: StepFacts, config: RewardConfig, shaping: CteShaping | None
) -> float | None:
    """``off_road``: the penalty per wheel on grass."""
    if facts.wheels_on_grass and config.off_road_penalty:
        return -config.off_road_penalty * facts.wheels_on_grass
    return None


def obstacles_term(
    facts: StepFacts, config: RewardConfig, shaping: CteShaping | None
) -> float | None:
    """``obstacles``: the rewards of the obstacle colours touched (``done`` ones end instead)."""
    total = sum(
        reward
        for i in facts.obstacles_hit
        if (reward := config.color_obstacles[i].reward) != "done"
    )
    return float(total) if total else None


def cte_term(facts: StepFacts, config: RewardConfig, shaping: CteShaping | None) -> float | None:
    """``cte``: the shaping of the cross-track error."""
    if shaping is not None and facts.cte is not None:
        return float(shaping(facts.cte))
    return None


def cones_term(facts: StepFacts, config: RewardConfig, shaping: CteShaping | None) -> float | None:
    """``cones``: the penalty per cone knocked over (cone maps)."""
    if facts.cones_hit and config.cone_penalty:
        return -config.cone_penalty * facts.cones_hit
    return None


def walls_term(facts: StepFacts, config: RewardConfig, shaping: CteShaping | None) -> float | None:
    """``walls``: the penalty for a step against a wall (ROS maps)."""
    if facts.wall_hit and config.wall_penalty:
        return -config.wall_penalty
    return None


# The terms by name, in the order they are summed (the order is part of the float result).
REWARD_TERMS: dict[str, RewardTerm] = {
    "time": time_term,
    "tiles": tiles_term,
    "off_road": off_road_term,
    "obstacles": obstacles_term,
    "cones": cones_term,
    "walls": walls_term,
    "cte": cte_term,
}
UNCHARGED_AT_RESET = ("time",)  # terms the step that reset takes with no action does not pay

# When a term can pay at all, by name: a term whose weight is zero (or that has nothing to
# pay for) returns None on every step, so ``active_terms`` leaves it out. A term without
# an entry here is always asked.
CAN_PAY: dict[str, Callable[[RewardConfig, CteShaping | None], bool]] = {
    "time": lambda config, shaping: bool(config.time_penalty),
    "tiles": lambda config, shaping: bool(config.tile_progress),
    "off_road": lambda config, shaping: bool(config.off_road_penalty),
    "obstacles": lambda config, shaping: any(
        o.reward != "done" and o.reward for o in config.color_obstacles
    ),
    "cones": lambda config, shaping: bool(config.cone_penalty),
    "walls": lambda config, shaping: bool(config.wall_penalty),
    "cte": lambda config, shaping: shaping is not None,
}


def active_terms(config: RewardConfig, shaping: CteShaping | None) -> dict[str, RewardTerm]:
    """The terms of ``REWARD_TERMS`` (in its order) that can pay under ``config``."""
    return {
        name: term
        for name, term in REWARD_TERMS.items()
        if name not in CAN_PAY or CAN_PAY[name](config, shaping)
    }


def reward_terms(
    facts: StepFacts,
    config: RewardConfig,
    shaping: CteShaping | None,
    charge_time: bool = True,
    terms_to_ask: Mapping[str, RewardTerm] = REWARD_TERMS,
) -> dict[str, float]:
    """Named reward terms of one step.

    Leaving the bounds replaces every other term with the penalty, as CarRacing does.
    ``charge_time`` is False for the step that ``reset`` takes with no action.
    ``terms_to_ask``: ``active_terms(config, shaping)`` saves asking terms that cannot pay.
    """
    if facts.out_of_bounds:
        return (
            {"out_of_bounds": -config.out_of_bounds_penalty} if config.out_of_bounds_penalty else {}
        )
    terms: dict[str, float] = {}
    for name, term in terms_to_ask.items():
        if not charge_time and name in UNCHARGED_AT_RESET:
            continue
        value = term(facts, config, shaping)
        if value is not None:
            terms[name] = value
    return terms


def ends_episode(facts: StepFacts, config: RewardConfig) -> str | None:
    """Why the episode terminates after this step, or None."""
    if facts.out_of_bounds:
        return "out_of_bounds"
    if facts.obstacles_hit and any(
        config.color_obstacles[i].reward == "done" for i in facts.obstacles_hit
    ):
        return "obstacle"
    if facts.collision_ends:
        return "collision"
    if facts.lap_finished:
        return "lap_finished"
    return None
