"""The ``opponents`` sensor (sensors/opponents.py): the nearest other cars in the car's frame,
against a hand computation with a rotation matrix, and in races."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.cars.state import CarState
from tinyrace.config.sensors import OpponentsConfig
from tinyrace.errors import ConfigError
from tinyrace.race import parallel_env
from tinyrace.sensors.opponents import COLUMNS, OpponentsSensor
from tinyrace.world.snapshot import Snapshot


def car(x, y, heading, vx, vy, length=2.0, width=1.0) -> CarState:
    """A car whose rear axle is at (x, y)."""
    front = (x + length * math.cos(heading), y + length * math.sin(heading))
    return CarState(
        model="test",
        pose=(x, y, heading),
        velocity=(vx, vy),
        speed=math.hypot(vx, vy),
        yaw_rate=0.0,
        steer=0.0,
        front_axle=front,
        rear_axle=(x, y),
        footprint=(length, width),
    )


def by_hand(me: CarState, other: CarState, y_down: bool) -> list[float]:
    """One row: the other car's footprint middle and velocity turned into my frame by the
    rotation matrix R(-heading), y (and angles) flipped on y-down tracks (y points down, so
    'left' is -y there)."""
    h = me.pose[2]
    rotate = np.array([[math.cos(h), math.sin(h)], [-math.sin(h), math.cos(h)]])  # R(-h)
    middle = np.array(other.rear_axle) + other.footprint[0] / 2 * np.array(
        [math.cos(other.pose[2]), math.sin(other.pose[2])]
    )
    x, y = rotate @ (middle - np.array(me.front_axle))
    vx, vy = rotate @ (np.array(other.velocity) - np.array(me.velocity))
    turn = math.remainder(other.pose[2] - h, 2 * math.pi)
    flip = -1.0 if y_down else 1.0
    return [1.0, x, flip * y, vx, flip * vy, flip * turn]


coordinate = st.floats(-50, 50)
angle = st.floats(-math.pi, math.pi)
velocity = st.floats(-20, 20)
pose = st.tuples(coordinate, coordinate, angle, velocity, velocity)


@settings(max_examples=examples(300), deadline=None)
@given(
    me=pose,
    others=st.lists(pose, max_size=6),
    count=st.integers(1, 5),
    max_range=st.floats(5, 120),
    y_down=st.booleans(),
)
@example(  # two cars equally near; a heading of 1e-308 leaves -0.0 and -1e-308 in the rows
    me=(0.0, 0.0, -1.1125369292536007e-308, 0.0, 0.0),
    others=[(0.0, 1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0, 1.0)],
    count=2,
    max_range=5.0,
    y_down=False,
)
def test_rows_equal_a_hand_rotation_nearest_first_in_range_padded(
    me, others, count, max_range, y_down
):
    config = OpponentsConfig(id="opponents", count=count, max_range=max_range)
    sensor = OpponentsSensor(config, max_range, top_speed=40.0, y_down=y_down)
    cars = (car(*me), *(car(*o) for o in others))
    got = sensor.observe(Snapshot(0.0, 0, cars), None, np.random.default_rng(0))  # type: ignore[arg-type]
    assert got.shape == (count, len(COLUMNS)) and got.dtype == np.float32
    rows = [by_hand(cars[0], other, y_down) for other in cars[1:]]
    near = sorted(
        (r for r in rows if math.hypot(r[1], r[2]) <= max_range), key=lambda r: math.hypot(*r[1:3])
    )[:count]
    want = np.zeros((count, len(COLUMNS)))
    want[: len(near)] = np.reshape(near, (-1, len(COLUMNS)))
    distances = [math.hypot(*r[1:3]) for r in rows]
    if any(abs(d - max_range) < 1e-6 for d in distances):
        return  # a car on the range's edge: either side is right
    if any(abs(a - b) < 1e-6 for i, a in enumerate(distances) for b in distances[i + 1 :]):
        # equally near: order free (rows sorted by their values to 4 decimals: a heading of
        # 1e-308 leaves -1e-308 in one row and -0.0 in the other, which would sort apart)
        want = want[np.lexsort(np.round(want, 4).T[::-1])]
        got = got[np.lexsort(np.round(got, 4).T[::-1])]
    if np.abs(want[:, 5]).max(initial=0) > math.pi - 1e-6:
        want[:, 5], got[:, 5] = np.abs(want[:, 5]), np.abs(got[:, 5])  # -pi and pi
    assert np.allclose(got, want, rtol=1e-5, atol=1e-4), (got, want)
    assert got in sensor.space


def test_a_car_alone_sees_only_padding():
    env = gym.make("tinyrace/TinyRace-v0", sensors=[{"id": "opponents", "type": "opponents"}])
    observation, _ = env.reset(seed=0)
    assert observation["opponents"].shape == (3, 6)
    assert not observation["opponents"].any()


def test_in_a_race_each_car_sees_the_other_ahead_or_behind():
    env = parallel_env(
        environment="f1tenth_loop",
        num_agents=2,
        sensors=[{"id": "opponents", "type": "opponents", "count": 2}],
    )
    env.reset(seed=0)
    first = env.core.snapshot().cars[0]
    x, y, heading = first.pose
    length = first.footprint[0]
    gap = length + 2.0  # [m] car 1's rear axle 2 m ahead of car 0's front axle
    poses = [(x, y, heading), (x + gap * math.cos(heading), y + gap * math.sin(heading), heading)]
    observations, _ = env.reset(seed=0, options={"poses": poses})
    ahead, behind = observations["car_0"]["opponents"], observations["car_1"]["opponents"]
    assert ahead[0] == pytest.approx([1.0, 2.0 + length / 2, 0.0, 0.0, 0.0, 0.0], abs=1e-5)
    # from car 1's front axle back to the middle of car 0: its gap, its length, half of 0's
    assert behind[0] == pytest.approx([1.0, -(2.0 + 1.5 * length), 0.0, 0.0, 0.0, 0.0], abs=1e-5)
    assert not ahead[1].any() and not behind[1].any()  # one other car: one row of padding
    near = parallel_env(
        environment="f1tenth_loop",
        num_agents=2,
        sensors=[{"id": "opponents", "type": "opponents", "max_range": 1.0}],
    )
    observations, _ = near.reset(seed=0, options={"poses": poses})
    assert not observations["car_0"]["opponents"].any()  # beyond the range


def test_a_learner_sees_its_opponents():
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment="circuit",
        opponents=[{"driver": "centerline"}, {"driver": "centerline", "speed": 0.5}],
        sensors=[{"id": "opponents", "type": "opponents", "count": 3}],
    )
    observation, _ = env.reset(seed=0)
    for _ in range(40):
        observation, *_ = env.step(np.zeros(env.action_space.shape, np.float32))
        assert observation in env.observation_space
    rows = observation["opponents"]
    assert rows[:, 0].tolist() == [1.0, 1.0, 0.0]
    distances = np.hypot(rows[:2, 1], rows[:2, 2])
    assert distances[0] <= distances[1]
    assert (rows[:2, 3] > 0).all()  # they drive off; the learner idles: they pull away ahead


def test_a_bad_count_is_a_config_error_naming_the_key():
    with pytest.raises(ConfigError, match=r"sensors\[0\]\.count"):
        gym.make("tinyrace/TinyRace-v0", sensors=[{"id": "o", "type": "opponents", "count": 0}])


def test_a_car_gone_from_the_track_is_not_reported():
    config = OpponentsConfig(id="opponents", count=3, max_range=50.0)
    sensor = OpponentsSensor(config, 50.0, top_speed=40.0, y_down=False)
    cars = (car(0, 0, 0, 0, 0), car(5, 0, 0, 0, 0), car(10, 0, 0, 0, 0))
    rng = np.random.default_rng(0)
    both = sensor.observe(Snapshot(0.0, 0, cars), None, rng)  # type: ignore[arg-type]
    assert both[:, 0].tolist() == [1.0, 1.0, 0.0]
    # the nearer car finished its race: only the farther one is left, first
    seen = sensor.observe(Snapshot(0.0, 0, cars, gone=frozenset({1})), None, rng)  # type: ignore[arg-type]
    assert seen[:, 0].tolist() == [1.0, 0.0, 0.0]
    assert seen[0].tolist() == both[1].tolist()
