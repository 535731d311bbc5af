"""The car on pymunk against CarRacing-v3's Box2D car (issue #2, point 4).

Both envs are driven with the same actions from the same seed; tinyrace's speed is
``info["speed"]``, the reference's is the hull's linear velocity.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pymunk
import pytest

import tinyrace  # noqa: F401
from tinyrace.cars.dynamic import DynamicCar

GAS = np.array([0.0, 1.0, 0.0], np.float32)
BRAKE = np.array([0.0, 0.0, 1.0], np.float32)
CHECKPOINTS = (25, 50, 100)  # [steps] of full gas


def drive(env_id: str, seed: int, actions: list[np.ndarray]) -> np.ndarray:
    """Rows (x, y, hull angle, speed) after each action."""
    env = gym.make(env_id)
    env.reset(seed=seed)
    rows = []
    for action in actions:
        env.step(action)
        car = env.unwrapped.car
        if env_id.startswith("tinyrace/"):
            x, y, heading = car.pose
            rows.append((x, y, heading - math.pi / 2, car.speed))
        else:
            (x, y), hull = car.hull.position, car.hull
            rows.append((x, y, hull.angle, hull.linearVelocity.length))
    env.close()
    return np.array(rows)


@pytest.fixture(scope="module", params=[0, 1, 2])
def full_gas(request) -> tuple[np.ndarray, np.ndarray]:
    actions = [GAS] * 100
    seed = request.param
    return drive("tinyrace/CarRacing-v0", seed, actions), drive("CarRacing-v3", seed, actions)


def test_speed_under_full_gas_matches_carracing_v3(full_gas) -> None:
    ours, reference = full_gas
    for steps in CHECKPOINTS:
        assert ours[steps - 1, 3] == pytest.approx(reference[steps - 1, 3], rel=0.10)
    assert reference[24, 3] > 20  # the reference really accelerated


def test_position_matches_carracing_v3_step_by_step(full_gas) -> None:
    """Velocities change before positions, as in Box2D: no one-step lag (speed * dt)."""
    ours, reference = full_gas
    gap = np.linalg.norm(ours[:50, :2] - reference[:50, :2], axis=1)
    assert gap.max() < 0.25  # [u]; one step of lag would be 0.9 u at step 50


def test_steering_turns_like_carracing_v3() -> None:
    actions = [GAS] * 50 + [np.array([-0.5, 0.0, 0.0], np.float32)] * 20
    ours, reference = drive("tinyrace/CarRacing-v0", 0, actions), drive("CarRacing-v3", 0, actions)
    turned, turned_reference = ours[-1, 2] - ours[49, 2], reference[-1, 2] - reference[49, 2]
    assert turned_reference > 1.0  # [rad] steer -0.5 turns left (counter-clockwise)
    assert turned == pytest.approx(turned_reference, rel=0.10)


def test_full_brake_stops_the_car_like_carracing_v3() -> None:
    actions = [GAS] * 60 + [BRAKE] * 40
    ours, reference = drive("tinyrace/CarRacing-v0", 1, actions), drive("CarRacing-v3", 1, actions)
    assert ours[59, 3] > 40
    stop, stop_reference = (int(np.argmax(run[60:, 3] < 0.5)) for run in (ours, reference))
    assert ours[-1, 3] < 1e-6 and reference[-1, 3] < 1e-6
    assert 5 < stop <= stop_reference + 3
    # and it stays put once stopped
    np.testing.assert_allclose(ours[-1, :2], ours[60 + stop + 5, :2], atol=0.05)


# -- grip: road against grass ----------------------------------------------------------------
def accelerate(on_road: bool, steps: int = 25) -> float:
    """Speed [u/s] after full gas on a bare pymunk space, every wheel on road or on grass."""
    space = pymunk.Space()
    car = DynamicCar.build(space, (0.0, 0.0, math.pi / 2))
    for _ in range(steps):
        car.control(0.0, 1.0, 0.0)
        car.apply_forces(1 / 50, [on_road] * 4)
        space.step(1 / 50)
    return car.speed


def test_grass_grips_less_than_road() -> None:
    road, grass = accelerate(True), accelerate(False)
    # a wheel spinning under full gas is friction-limited: grass gives 0.6 of the road's limit
    assert grass == pytest.approx(0.6 * road, rel=0.05)


def test_car_on_grass_in_the_env_accelerates_slower() -> None:
    """The same start, once on the road and once moved onto grass next to it."""
    speeds, grass_wheels = [], []
    for offset in (0.0, 30.0):  # [u] sideways from the start point
        env = gym.make("tinyrace/CarRacing-v0")
        env.reset(seed=0)
        track, car = env.unwrapped.track, env.unwrapped.car
        heading = car.pose[2]
        side = np.array([math.sin(heading), -math.cos(heading)])  # to the car's right
        spot = track.centerline[0] + offset * side
        distance = np.linalg.norm(track.centerline - spot, axis=1).min()
        assert distance == pytest.approx(offset, abs=1.0)  # no other road nearby
        car.body.position = tuple(spot)
        env.step(np.zeros(3, np.float32))  # the sensors report what is under the wheels
        for _ in range(25):
            _, _, _, _, info = env.step(GAS)
        speeds.append(info["speed"])
        grass_wheels.append(info["wheels_on_grass"])
    assert grass_wheels == [0, 4]
    assert speeds[1] == pytest.approx(0.6 * speeds[0], rel=0.1)
