"""State core: speeds, rates and wheel slip in the car's frame on both track conventions; pose
bounds."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the envs)
from tinyrace.cars.state import CarState, WheelState
from tinyrace.sensors.state import fields, state_vector

ID = "tinyrace/TinyRace-v0"


def _car(pose, velocity, yaw_rate=0.0, steer=0.0, wheels=()):
    return CarState(
        model="dynamic",
        pose=pose,
        velocity=velocity,
        speed=math.hypot(*velocity),
        yaw_rate=yaw_rate,
        steer=steer,
        front_axle=(0.0, 0.0),
        rear_axle=(0.0, 0.0),
        footprint=(1.0, 1.0),
        wheels=wheels,
    )


@pytest.mark.parametrize("y_down", [False, True])
def test_speeds_in_the_car_frame(y_down):
    heading = 0.7
    ahead = (math.cos(heading), math.sin(heading))
    left = (-ahead[1], ahead[0]) if not y_down else (ahead[1], -ahead[0])
    velocity = (3 * ahead[0] + 2 * left[0], 3 * ahead[1] + 2 * left[1])
    turn = -1 if y_down else 1  # a track-frame rate of +0.5 is a left turn on y-up only
    vector = state_vector(_car((1, 2, heading), velocity, 0.5, 0.1), y_down, False, False)
    np.testing.assert_allclose(vector, [3, 2, turn * 0.5, turn * 0.1], rtol=1e-6)


def test_wheel_speeds_and_slip_and_pose():
    wheels = tuple(WheelState(omega, 0.0, 0.5) for omega in (10, 10, 12, 8))
    car = _car((5.0, 6.0, 3 * math.pi), (4.0 * -1, 0.0), wheels=wheels)  # heading pi: -x
    vector = state_vector(car, False, True, True)
    names = fields(True, True)
    assert len(vector) == len(names) == 4 + 8 + 3 and vector.dtype == np.float32
    value = dict(zip(names, vector, strict=True))
    assert value["speed_long"] == pytest.approx(4.0)
    assert [value[f"wheel_speed_{w}"] for w in ("fl", "fr", "rl", "rr")] == [5, 5, 6, 4]
    assert [value[f"slip_{w}"] for w in ("fl", "fr", "rl", "rr")] == pytest.approx([1, 1, 2, 0])
    assert value["heading"] == pytest.approx(-math.pi) and (value["x"], value["y"]) == (5, 6)


def test_pose_bounds_hold_the_last_pose_before_leaving_the_playfield():
    """On a procedural track x and y are bounded by the playfield widened by a step's travel:
    the pose of the step that leaves the playfield is still inside the box, unclipped."""
    env = gym.make(ID, sensors=[{"id": "s", "type": "state", "pose": True}])
    space = env.observation_space["s"]
    playfield = env.unwrapped.config.tracks[0].playfield
    assert playfield < space.high[-3] < 1.1 * playfield and space.high[-3] == space.high[-2]
    observation, _ = env.reset(seed=0)
    for _ in range(2000):  # straight on at a fifth of the throttle: off the playfield
        observation, _, terminated, truncated, info = env.step(np.array([0.0, 0.2, 0.0]))
        if terminated or truncated:
            break
    assert info["termination"] == "out_of_bounds"
    x, y = observation["s"][-3:-1]
    assert max(abs(x), abs(y)) > playfield and space.contains(observation["s"])
    pose = env.unwrapped.snapshot().car.pose
    np.testing.assert_allclose((x, y), pose[:2], rtol=1e-6)  # not clipped
    env.close()


def test_pose_is_unbounded_where_the_extent_is_read_at_reset():
    env = gym.make(ID, environment="circuit", sensors=[{"id": "s", "type": "state", "pose": True}])
    assert np.isinf(env.observation_space["s"].high[-3:-1]).all()
    env.close()
