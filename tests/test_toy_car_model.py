"""Adding a car model is one module and one registry entry: this file is the module. A toy
car registered here alone drives through gym.make, a sensor and the centreline driver."""

from __future__ import annotations

import math
from collections.abc import Iterator

import gymnasium as gym
import numpy as np
import pymunk
import pytest
from test_steer_convention import turn_after

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.actions import ActionSpec
from tinyrace.cars.base import Car, Pose
from tinyrace.cars.collision import footprint_sensor
from tinyrace.cars.registry import POSITIVE_STEER_TURNS, CarModel, register, unregister
from tinyrace.cars.state import CarFacts, CarState
from tinyrace.config import CarConfig, EnvConfig
from tinyrace.drivers.centerline import CenterlineDriver
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.tracks.base import Track

LENGTH, WIDTH, TOP_SPEED, LOCK = 1.2, 0.8, 6.0, 0.5  # [m], [m], [m/s], [rad]


class Hopper:
    """A toy car: a unicycle whose action is [turn -1..1 (+ left, as every car in metres),
    speed 0..1 of the top]."""

    def __init__(self, space: pymunk.Space, pose: Pose):
        self.body = pymunk.Body(1.0, math.inf)
        self.body.position, self.body.angle = pose[:2], pose[2]
        space.add(self.body, footprint_sensor(self.body, (0.0, -WIDTH / 2), (LENGTH, WIDTH / 2)))
        self.turn, self.v = 0.0, 0.0

    def control(self, turn: float, speed: float) -> None:
        self.turn, self.v = turn, speed * TOP_SPEED

    def apply_forces(self, dt: float, on_road: object = None) -> None:
        heading = self.body.angle
        self.body.velocity = (self.v * math.cos(heading), self.v * math.sin(heading))
        self.body.angular_velocity = self.turn * LOCK * self.v / LENGTH  # + left, y up

    def stop(self) -> None:
        self.v = 0.0
        self.body.velocity, self.body.angular_velocity = (0.0, 0.0), 0.0

    @property
    def pose(self) -> Pose:
        x, y = self.body.position
        return x, y, self.body.angle

    @property
    def speed(self) -> float:
        return self.v

    @property
    def footprint(self) -> tuple[float, float]:
        return LENGTH, WIDTH

    @property
    def rear_axle(self) -> tuple[float, float]:
        x, y = self.body.position
        return x, y

    @property
    def front_axle(self) -> tuple[float, float]:
        x, y, heading = self.pose
        return x + LENGTH * math.cos(heading), y + LENGTH * math.sin(heading)

    def state(self) -> CarState:
        vx, vy = self.body.velocity
        return CarState(
            "hopper", self.pose, (vx, vy), self.v, self.body.angular_velocity, 0.0,
            self.front_axle, self.rear_axle, (LENGTH, WIDTH), hull_angle=self.body.angle,
        )  # fmt: skip


def build(space: pymunk.Space, pose: Pose, config: CarConfig, track: Track) -> Car:
    return Hopper(space, pose)


def facts(config: EnvConfig) -> CarFacts:
    return CarFacts(LENGTH, WIDTH, TOP_SPEED, TOP_SPEED * LOCK / LENGTH, LOCK, -1.0 / LOCK)


HOPPER = CarModel(
    name="hopper",
    track_units=frozenset({"m"}),
    default_for=frozenset(),
    action_kinds=frozenset({"continuous"}),
    build=build,
    actions=lambda config: ActionSpec.box((-1.0, 0.0), (1.0, 1.0), "steer_throttle"),
    facts=facts,
    wheels=False,
    throttle=True,
    units="m",
    doc="a toy unicycle",
)


@pytest.fixture
def hopper() -> Iterator[None]:
    register(HOPPER)
    yield
    unregister("hopper")


def test_a_toy_model_drives_through_make_a_sensor_and_the_centreline_driver(hopper):
    state = {"id": "motion", "type": "state"}
    lidar = {"id": "scan", "type": "lidar", "beams": 8}
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment=str(TRACKS_DIR / "circuit"),
        car={"model": "hopper"},
        sensors=[state, lidar],
        observation="dict",
    )
    assert env.unwrapped.car_facts.length == LENGTH and not env.unwrapped.car_facts.wheels
    assert env.observation_space["motion"].high[0] == pytest.approx(TOP_SPEED)
    driver = CenterlineDriver()
    observation, info = env.reset(seed=0)
    driver.reset(env)
    assert driver.route is not None and driver.route.steer_lock == LOCK
    start = np.array(info["pose"][:2])
    for _ in range(200):
        observation, _, terminated, truncated, info = env.step(driver.act(observation, info))
        assert not (terminated or truncated)
    assert observation["motion"][0] > 0.25 * TOP_SPEED  # it drives forward
    assert np.hypot(*(np.array(info["pose"][:2]) - start)) > 10.0  # [m] of 4 s at <= 6 m/s
    assert info["tiles_visited"] > 5 and info["on_road"]
    env.close()


def test_a_toy_model_keeps_the_steering_convention_of_tracks_in_metres(hopper):
    """What tests/test_steer_convention.py asks of every shipped model, asked of the toy:
    the recipe's car is one to copy into the package."""
    assert turn_after("hopper", "continuous", "centerline") == POSITIVE_STEER_TURNS["m"]
    env = gym.make("tinyrace/TinyRace-v0", environment="circuit", car={"model": "hopper"})
    assert env.unwrapped.car_facts.steer_per_rad < 0  # a positive command turns left
    env.close()


def test_a_model_that_does_not_drive_there_is_refused(hopper):
    with pytest.raises(ConfigError, match="hopper"):
        # it drives in metres, the image track is in pixels
        gym.make("tinyrace/TinyRace-v0", environment=str(TRACKS_DIR / "formula_student"),
                 car={"model": "hopper"})  # fmt: skip
