"""Rewards are decided here, and only here, from the facts of a step.

Each term is named; the step's reward is their sum and the terms are reported
in ``info["reward_terms"]`` so that a reward design can be inspected.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

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


def reward_terms(
    facts: StepFacts, config: RewardConfig, shaping: CteShaping | None, charge_time: bool = True
) -> dict[str, float]:
    """Named reward terms of one step.

    Leaving the bounds replaces every other term with the penalty, as CarRacing does.
    ``charge_time`` is False for the step that ``reset`` takes with no action.
    """
    if facts.out_of_bounds:
        return (
            {"out_of_bounds": -config.out_of_bounds_penalty} if config.out_of_bounds_penalty else {}
        )
    terms: dict[str, float] = {}
    if charge_time and config.time_penalty:
        terms["time"] = -config.time_penalty
    if facts.new_tiles and config.tile_progress:
        terms["tiles"] = config.tile_progress * facts.new_tiles / facts.tiles_total
    if facts.wheels_on_grass and config.off_road_penalty:
        terms["off_road"] = -config.off_road_penalty * facts.wheels_on_grass
    obstacle_reward = sum(
        reward
        for i in facts.obstacles_hit
        if (reward := config.color_obstacles[i].reward) != "done"
    )
    if obstacle_reward:
        terms["obstacles"] = float(obstacle_reward)
    if facts.cones_hit and config.cone_penalty:
        terms["cones"] = -config.cone_penalty * facts.cones_hit
    if facts.wall_hit and config.wall_penalty:
        terms["walls"] = -config.wall_penalty
    if shaping is not None and facts.cte is not None:
        terms["cte"] = float(shaping(facts.cte))
    return terms


def ends_episode(facts: StepFacts, config: RewardConfig) -> str | None:
    """Why the episode terminates after this step, or None."""
    if facts.out_of_bounds:
        return "out_of_bounds"
    if any(config.color_obstacles[i].reward == "done" for i in facts.obstacles_hit):
        return "obstacle"
    if facts.collision_ends:
        return "collision"
    if facts.lap_finished:
        return "lap_finished"
    return None
