"""Any action sequence is safe for the single-track car (issue 38, point 7): random
action sequences, held for random stretches (both action modes, every preset, 50 and 100
Hz, long episodes, reversing included), keep its state finite and bounded and raise
nothing (before this change every one of the runs in the open below failed: 17 of this
file's 19 tests); and random actions on f1tenth_loop, where users met it, raise nothing."""

from __future__ import annotations

import math

import gymnasium as gym
import pymunk
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs
from hypothesis_budget import examples, size

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.cars import single_track_model as st
from tinyrace.cars.single_track import SingleTrackCar

FRACTION = hs.sampled_from([0.0, 0.5, 1.0]) | hs.floats(0.0, 1.0)  # of the action's range
PIECES = hs.lists(  # (steps held, steering fraction, speed or acceleration fraction)
    hs.tuples(hs.integers(1, 150), FRACTION, FRACTION),
    min_size=1,
    max_size=size(40, 12),
)


def limits(p: st.VehicleParameters, raw: bool) -> tuple[tuple[float, float], tuple[float, float]]:
    """The action space's (low, high), as the registry builds it."""
    if raw:
        return (p.steer_rate_min, -p.a_max), (p.steer_rate_max, p.a_max)
    return (p.steer_min, p.v_min), (p.steer_max, p.v_max)


def drive(preset: str, raw: bool, fps: int, pieces: list[tuple[int, float, float]]) -> int:
    """Drive the pieces; assert the state after every step; the steps driven."""
    p = st.PRESETS[preset]
    space = pymunk.Space()
    car = SingleTrackCar.build(space, (3.0, -1.0, 0.5), p, raw=raw)
    (lo_a, lo_b), (hi_a, hi_b) = limits(p, raw)
    dt = 1.0 / fps
    top = max(p.v_max, -p.v_min)  # [m/s]
    yaw_bound = 2 * top * math.tan(max(p.steer_max, -p.steer_min)) / p.wheelbase  # [rad/s]
    steps = 0
    for held, a, b in pieces:
        action = (lo_a + a * (hi_a - lo_a), lo_b + b * (hi_b - lo_b))
        for _ in range(held):
            x0, y0, psi0 = car.pose
            car.control(*action)
            car.apply_forces(dt)
            space.step(dt)
            steps += 1
            x, y, psi = car.pose
            state = (x, y, psi, car.delta, car.v, car.yaw_rate, car.slip)
            assert all(math.isfinite(value) for value in state), state
            assert p.steer_min <= car.delta <= p.steer_max
            assert p.v_min <= car.v <= p.v_max
            assert abs(car.yaw_rate) <= yaw_bound, state
            assert abs(car.slip) <= math.pi, state
            # a step that reaches the top speed part way integrates a little past it
            assert math.hypot(x - x0, y - y0) <= top * dt * 1.01, state
            assert abs(psi - psi0) <= yaw_bound * dt, state
    return steps


@pytest.mark.parametrize("fps", [50, 100])
@pytest.mark.parametrize("raw", [False, True], ids=["continuous", "raw"])
@pytest.mark.parametrize("preset", sorted(st.PRESETS))
@settings(max_examples=examples(12), deadline=None)
@given(pieces=PIECES)
def test_any_action_sequence_keeps_the_state_finite_and_bounded(preset, raw, fps, pieces):
    assert drive(preset, raw, fps, pieces) == sum(held for held, _, _ in pieces)


def test_hard_braking_into_reverse_while_turning_at_speed_stays_bounded():
    """What random actions met first: at 15 m/s with the wheels turned, asked for reverse
    (the speed controller brakes at full force: the linear tyres' oversteer spun the car
    up until its yaw rate read 3e6 rad/s), then reversing at full lock."""
    for raw in (False, True):
        plan = [(150, 1.0, 0.85), (100, 0.0, 0.0), (200, 1.0, 0.0), (200, 0.0, 0.0)]
        if raw:  # steer left, accelerate, then brake hard steering right
            plan = [(150, 0.6, 1.0), (100, 0.0, 0.0), (200, 1.0, 0.0), (200, 0.0, 0.3)]
        assert drive("f1tenth", raw, 50, plan) == 650


@pytest.mark.parametrize("actions", ["continuous", "raw"])
def test_random_actions_on_f1tenth_loop_raise_nothing(actions):
    """Where a user met the crash: random actions (what an RL agent explores) on
    f1tenth_loop with the f1tenth preset, walls and resets included (the runs above, in the
    open, are what found the blow-ups: this one checks the env's path)."""
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment="f1tenth_loop",
        car={"model": "single_track", "actions": actions},
        cameras=[],
        sensors=[{"id": "state", "type": "state"}],
    )
    env.action_space.seed(38)
    env.reset(seed=38)
    reversed_steps = 0
    for step in range(size(3000, 1000)):
        if step % 25 == 0:  # held a while, as an agent repeating its actions
            action = env.action_space.sample()
        _, reward, terminated, truncated, info = env.step(action)
        assert all(math.isfinite(v) for v in info["pose"]) and math.isfinite(info["speed"])
        assert math.isfinite(reward)
        reversed_steps += info["speed"] < -0.5
        if terminated or truncated:
            env.reset()
    env.close()
    assert reversed_steps > 20  # it did reverse beyond the low-speed model's switch
