"""A step asks only the reward terms its design can pay: the same terms come out, summed
in the registry's order (the built-in parts' order is part of every float result)."""

from __future__ import annotations

import dataclasses

from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

import tinyrace.episodes.rules  # noqa: F401  (registers the built-in rule parts' terms)
from tinyrace.config.colors import Color
from tinyrace.config.schema import ColorObstacle, RewardConfig
from tinyrace.rewards import TERMS, Design, Shaping, judging, reward_terms
from tinyrace.world.facts import StepFacts

weights = st.sampled_from([0.0, 0.1, 1.0, 5.0])
obstacle_rewards = st.lists(st.sampled_from([0.0, -1.0, 2.5, "done"]), max_size=3)


@settings(max_examples=examples(300), deadline=None)
@given(
    time=weights,
    tiles=weights,
    off_road=weights,
    cones=weights,
    walls=weights,
    rewards=obstacle_rewards,
    shaped=st.booleans(),
    new_tiles=st.integers(0, 2),
    on_grass=st.integers(0, 4),
    cones_hit=st.integers(0, 2),
    wall_hit=st.booleans(),
    cte=st.none() | st.floats(0.0, 10.0),
    hits=st.lists(st.integers(0, 2), max_size=3),
)
def test_active_terms_give_the_terms_of_all_terms(
    time,
    tiles,
    off_road,
    cones,
    walls,
    rewards,
    shaped,
    new_tiles,
    on_grass,
    cones_hit,
    wall_hit,
    cte,
    hits,
) -> None:
    obstacles = tuple(ColorObstacle(Color.rgb(9 * i, 0, 0), r) for i, r in enumerate(rewards))
    config = dataclasses.replace(
        RewardConfig(),
        time_penalty=time,
        tile_progress=tiles,
        off_road_penalty=off_road,
        cone_penalty=cones,
        wall_penalty=walls,
        color_obstacles=obstacles,
    )
    shaping = Shaping("linear", 2.0, 1.0) if shaped else None
    facts = StepFacts(
        new_tiles=new_tiles,
        tiles_total=10,
        wheels_on_grass=on_grass,
        obstacles_hit=[i for i in hits if i < len(obstacles)],
        cte=cte,
        cones_hit=cones_hit,
        wall_hit=wall_hit,
    )
    design = Design(config, shaping)
    every = [term for term in TERMS.values() if term.alone is None]
    active = judging(TERMS, (), design).terms
    assert [t.name for t in active] == [t.name for t in every if t in active]  # order kept
    expected = reward_terms(facts, design, every)
    assert reward_terms(facts, design, active) == expected
    assert list(reward_terms(facts, design, active)[0]) == list(expected[0])


def test_terms_with_nothing_to_pay_are_not_asked() -> None:
    config = dataclasses.replace(RewardConfig(), time_penalty=0.1, tile_progress=1000.0)
    # no off-road penalty, no obstacle colours, no cte shaping
    names = [t.name for t in judging(TERMS, (), Design(config)).terms]
    assert names == ["time", "tiles", "cones", "walls"]


def test_the_built_in_terms_are_summed_in_their_historical_order() -> None:
    built_in = ["time", "out_of_bounds", "tiles", "off_road", "obstacles", "cones", "walls", "cte"]
    assert list(TERMS)[: len(built_in)] == built_in


def test_out_of_bounds_pays_alone_and_is_left_out_of_the_score() -> None:
    config = dataclasses.replace(RewardConfig(), time_penalty=0.1, out_of_bounds_penalty=100.0)
    judge = judging(TERMS, (), Design(config))
    facts = StepFacts(out_of_bounds=True, new_tiles=1, tiles_total=10)
    assert reward_terms(facts, Design(config), judge.terms, judge.alone) == (
        {"out_of_bounds": -100.0},
        True,
    )
    free = Design(dataclasses.replace(config, out_of_bounds_penalty=0.0))
    assert reward_terms(facts, free, judge.terms, judge.alone) == ({}, True)
