"""The dashboard redraws incrementally from cached pictures: never a stale pixel."""

from __future__ import annotations

import numpy as np
import pytest

from tinyrace.cars.state import CarState, WheelState
from tinyrace.sensors.machinery.dashboard import Dashboard


def _car(rng: np.random.Generator) -> CarState:
    steer = float(rng.uniform(-0.42, 0.42))
    spins = rng.uniform(-30.0, 300.0, 4) * rng.integers(0, 2, 4)  # some wheels locked (0)
    wheels = tuple(WheelState(float(w), steer, 1.0) for w in spins)
    speed, yaw = float(rng.uniform(0.0, 120.0)), float(rng.normal(0.0, 3.0))
    return CarState("dynamic", (0, 0, 0), (0, 0), speed, yaw, steer, (0, 0), (0, 0), (1, 1), wheels)


@pytest.mark.parametrize(("size", "factor"), [((96, 96), 4), ((600, 400), 1)])
def test_a_reused_dashboard_draws_what_a_fresh_one_draws(size, factor) -> None:
    rng = np.random.default_rng(7)
    reused = Dashboard(*size, supersample=factor)
    car = _car(rng)
    for step in range(300):
        if step % 3:  # small moves: many lengths round to the same pictures
            wheels = tuple(w._replace(omega=w.omega + rng.normal(0, 0.5)) for w in car.wheels)
            car = car._replace(speed=abs(car.speed + rng.normal(0, 0.2)), wheels=wheels)
        else:
            car = _car(rng)
        score = float(rng.uniform(-50, 900))
        got = np.zeros((size[1], size[0], 3), np.uint8)
        want = got.copy()
        reused.draw(got, car, score)
        Dashboard(*size, supersample=factor).draw(want, car, score)
        assert np.array_equal(got, want), f"step {step}"
