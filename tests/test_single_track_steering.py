"""A steering that settles (issue 38, point 2): a held steering angle is reached and held
at any sim rate, and the yaw rate then equals the single-track model's steady state; F1TENTH's
bang-bang controller (``car.compat: f1tenth_gym``) chatters about it."""

from __future__ import annotations

import numpy as np
import pymunk
import pytest

from tinyrace.cars import single_track_model as st
from tinyrace.cars.single_track import SingleTrackCar

ANGLE, SPEED = 0.4, 3.0  # [rad], [m/s]: the issue's case


def steady_yaw_rate(p: st.VehicleParameters, v: float, delta: float) -> float:
    """[rad/s] the yaw rate at which the linear single-track model's yaw and slip rates are 0
    at speed ``v`` and wheel angle ``delta`` (no acceleration): its derivatives are affine
    in (yaw rate, slip), so three evaluations give the 2x2 system to solve."""

    def rates(r: float, beta: float) -> np.ndarray:
        d = st.tyre_derivatives((0, 0, delta, v, 0, r, beta), 0.0, 0.0, p, guard=False)
        return np.array([d[5], d[6]])

    base = rates(0.0, 0.0)
    jacobian = np.column_stack([rates(1.0, 0.0) - base, rates(0.0, 1.0) - base])
    r, _ = np.linalg.solve(jacobian, -base)
    return float(r)


def hold(p: st.VehicleParameters, fps: float, seconds: float, compat: str | None = None):
    """(wheel angles, yaw rates) per step with (ANGLE, SPEED) held from rest."""
    space = pymunk.Space()
    car = SingleTrackCar.build(space, (0.0, 0.0, 0.0), p, compat=compat)
    angles, yaw_rates = [], []
    for _ in range(round(seconds * fps)):
        car.control(ANGLE, SPEED)
        car.apply_forces(1.0 / fps)
        space.step(1.0 / fps)
        angles.append(car.delta)
        yaw_rates.append(car.yaw_rate)
    return np.array(angles), np.array(yaw_rates)


def test_the_steady_state_is_the_issues():
    """The model's steady yaw rate at 0.4 rad and 3 m/s, as the issue computed it."""
    assert steady_yaw_rate(st.PRESETS["f1tenth"], SPEED, ANGLE) == pytest.approx(3.378, abs=1e-3)


@pytest.mark.parametrize("fps", [10, 20, 30, 50, 100, 240])
def test_a_held_angle_is_reached_and_held(fps):
    p = st.PRESETS["f1tenth"]
    angles, yaw_rates = hold(p, fps, 5.0)
    last = slice(-round(2 * fps), None)  # the last 2 s
    assert np.all(np.abs(angles[last] - ANGLE) <= 1e-12)  # reached, no chatter
    assert np.all(angles <= ANGLE + 1e-12)  # never past it
    reach = ANGLE / p.steer_rate_max  # [s] at full steering rate
    assert angles[int(np.ceil(reach * fps))] == pytest.approx(ANGLE, abs=1e-12)
    expected = steady_yaw_rate(p, SPEED, ANGLE)
    error = np.max(np.abs(yaw_rates[last] - expected)) / expected
    assert error < 0.01


@pytest.mark.parametrize("preset", ["vehicle1", "vehicle2", "vehicle3"])
def test_commonroads_cars_settle_too(preset):
    p = st.PRESETS[preset]
    angles, yaw_rates = hold(p, 50, 8.0)
    assert np.all(np.abs(angles[-100:] - ANGLE) <= 1e-12)
    expected = steady_yaw_rate(p, SPEED, ANGLE)
    assert np.max(np.abs(yaw_rates[-100:] - expected)) / expected < 0.01


def test_f1tenth_gyms_controller_chatters():
    """What tinyrace's controller replaces: F1TENTH's bang-bang steering at full rate with
    a 1e-4 rad dead band overshoots each step (3.2 rad/s * 0.01 s) and never settles."""
    angles, _ = hold(st.PRESETS["f1tenth"], 100, 5.0, compat="f1tenth_gym")
    last = angles[-200:]
    assert last.max() - last.min() > 0.01
    assert np.max(np.abs(last - ANGLE)) > 1e-4
