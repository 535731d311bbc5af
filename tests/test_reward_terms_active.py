"""A step asks only the reward terms its design can pay: the same terms come out."""

from __future__ import annotations

import dataclasses

from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

from tinyrace.config.colors import Color
from tinyrace.config.schema import ColorObstacle, RewardConfig
from tinyrace.rewards import REWARD_TERMS, Shaping, active_terms, reward_terms
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
    active = active_terms(config, shaping)
    assert list(active) == [name for name in REWARD_TERMS if name in active]  # order kept
    expected = reward_terms(facts, config, shaping)
    assert reward_terms(facts, config, shaping, True, active) == expected
    assert list(reward_terms(facts, config, shaping, True, active)) == list(expected)


def test_terms_with_nothing_to_pay_are_not_asked() -> None:
    config = dataclasses.replace(RewardConfig(), time_penalty=0.1, tile_progress=1000.0)
    # no off-road penalty, no obstacle colours, no cte shaping
    assert list(active_terms(config, None)) == ["time", "tiles", "cones", "walls"]
