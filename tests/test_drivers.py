"""The built-in drivers: registry, action adapters, and the centreline driver's laps."""

from __future__ import annotations

import math
import re

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import tinyrace  # noqa: F401
from tinyrace.drivers import (
    DRIVERS,
    ActionAdapter,
    CenterlineDriver,
    ConstantDriver,
    DiscreteChooser,
    Driver,
    DriverError,
    RandomDriver,
    check_action,
    make_driver,
    order_path,
    run_episode,
    speed_profile,
)
from tinyrace.examples import TRACKS_DIR

LAP_SEEDS = range(5)


def test_registry_names_and_lookup() -> None:
    assert set(DRIVERS) == {"random", "constant", "centerline"}
    for name in DRIVERS:
        assert isinstance(make_driver(name), Driver)
    assert isinstance(make_driver("centerline", lateral_accel=100.0), CenterlineDriver)
    with pytest.raises(ValueError, match="centerline, constant, random"):
        make_driver("centreline_typo")


def test_centerline_driver_finishes_laps_on_carracing() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    driver = CenterlineDriver()
    results = [run_episode(env, driver, seed=seed) for seed in LAP_SEEDS]
    returns = [episode_return for episode_return, _, _ in results]
    assert np.mean(returns) >= 850
    for _, steps, info in results:
        assert info["lap_finished"] is True and steps < 1000
        assert info["wheels_on_grass"] == 0


def test_centerline_driver_with_discrete_actions_stays_on_the_road() -> None:
    env = gym.make("tinyrace/CarRacing-v0", continuous=False)
    driver = CenterlineDriver()
    observation, info = env.reset(seed=1)
    driver.reset(env)
    on_grass, actions = 0, set()
    for _ in range(1000):
        action = driver.act(observation, info)
        assert env.action_space.contains(action)
        actions.add(action)
        observation, _, terminated, truncated, info = env.step(action)
        on_grass += info["wheels_on_grass"] > 2
        if terminated or truncated:
            break
    assert info["lap_finished"] is True  # 0.2 gas is slow, but this lap is short
    assert on_grass < 20
    assert {1, 2, 3} <= actions


def test_driver_is_reproducible_with_the_env() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    first = run_episode(env, CenterlineDriver(), seed=3, max_steps=200)
    second = run_episode(env, CenterlineDriver(), seed=3, max_steps=200)
    assert first == second and first[1] == 200


def test_constant_driver_gives_its_action_in_the_space() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    _, steps, info = run_episode(env, ConstantDriver((0.0, 1.0, 0.0)), seed=0, max_steps=50)
    assert steps == 50 and info["speed"] > 40
    discrete = gym.make("tinyrace/CarRacing-v0", continuous=False)
    driver = ConstantDriver(3)
    discrete.reset(seed=0)
    driver.reset(discrete)
    assert driver.act(None, {}) == 3


@pytest.mark.parametrize(
    ("kwargs", "expected"),
    [
        ({}, [0.0, 0.0, 0.0]),  # CarRacing's steer, gas, brake
        ({"environment": "circuit"}, [0.0, 0.0]),  # the kinematic car's steer and throttle
        ({"car": {"actions": "discrete"}}, 0),  # CarRacing's "nothing"
    ],
)
def test_constant_driver_does_nothing_by_default_in_any_action_space(kwargs, expected) -> None:
    env = gym.make("tinyrace/TinyRace-v0", **kwargs)
    driver = ConstantDriver()
    env.reset(seed=0)
    driver.reset(env)
    action = driver.act(None, {})
    assert env.action_space.contains(action)
    assert np.array_equal(action, expected)
    env.close()


def test_random_driver_samples_the_space_reproducibly() -> None:
    def episodes(seed: int) -> list[np.ndarray]:
        env, driver = gym.make("tinyrace/CarRacing-v0"), RandomDriver()
        actions = []
        for episode in range(2):
            env.reset(seed=seed if episode == 0 else None)
            state = env.unwrapped.np_random.bit_generator.state
            driver.reset(env)
            assert env.unwrapped.np_random.bit_generator.state == state  # env's rng untouched
            actions.append(np.array([driver.act(None, {}) for _ in range(20)]))
        assert all(env.action_space.contains(a) for a in actions[0])
        return actions

    first, again, other = episodes(5), episodes(5), episodes(6)
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first[0], first[1])  # a new episode, new actions
    assert not np.array_equal(first[0], other[0])
    assert np.std(first[0][:, 0]) > 0.2


# -- the parts -------------------------------------------------------------------------------
def test_adapter_for_box_spaces() -> None:
    box3 = ActionAdapter(spaces.Box(np.array([-1, 0, 0], np.float32), np.ones(3, np.float32)))
    np.testing.assert_array_equal(box3((-2.0, 0.5, 0.0)), np.array([-1, 0.5, 0], np.float32))
    steer_only = ActionAdapter(spaces.Box(-1.0, 1.0, (1,), np.float32))
    np.testing.assert_array_equal(steer_only((0.3, 1.0, 0.0)), np.array([0.3], np.float32))
    with pytest.raises(ValueError, match="Discrete"):
        ActionAdapter(spaces.MultiBinary(3))


def test_discrete_chooser_picks_the_nearest_action_in_effect() -> None:
    chooser = DiscreteChooser(dt=1 / 50)
    assert chooser.choose((0.0, 1.0, 0.0)) == 3  # gas
    assert DiscreteChooser(1 / 50).choose((0.0, 0.0, 1.0)) == 4  # brake
    assert DiscreteChooser(1 / 50).choose((0.0, 0.0, 0.0)) == 0  # nothing
    # hold a right turn of 0.2 rad: turn right until there, then alternate around it
    chooser = DiscreteChooser(1 / 50)
    picks = [chooser.choose((0.2, 0.0, 0.0)) for _ in range(20)]
    assert picks[:3] == [1, 1, 1]
    assert chooser.wheel == pytest.approx(0.2, abs=0.06)
    left = DiscreteChooser(1 / 50)
    assert [left.choose((-0.4, 1.0, 0.0)) for _ in range(3)] == [2, 2, 2]
    # gas wanted while turning: the pedal error is carried, so gas comes between turns
    mixed = DiscreteChooser(1 / 50)
    picks = [mixed.choose((0.1, 1.0, 0.0)) for _ in range(30)]
    assert picks.count(3) >= 10 and picks.count(1) >= 5


def test_speed_profile_limits_by_curvature_and_braking() -> None:
    angles = np.linspace(0, 2 * math.pi, 200, endpoint=False)
    circle = 50.0 * np.column_stack((np.cos(angles), np.sin(angles)))  # radius 50 u
    speeds = speed_profile(circle, top_speed=95.0, lateral_accel=100.0, brake_accel=90.0)
    np.testing.assert_allclose(speeds, math.sqrt(100.0 * 50.0), rtol=0.01)  # v^2 / r = a
    # a long loop: two straights joined by hairpins of radius 5 u
    half = np.linspace(0, math.pi, 30)
    bend = 5.0 * np.column_stack((np.sin(half), 1 - np.cos(half)))  # (0, 0) round to (0, 10)
    straight = np.column_stack((np.linspace(0, 300, 100, endpoint=False), np.zeros(100)))
    far, up = np.array([300.0, 0.0]), np.array([0.0, 10.0])
    loop = np.concatenate((straight, bend + far, straight[::-1] + up, up - bend))
    speeds = speed_profile(loop, top_speed=95.0, lateral_accel=100.0, brake_accel=90.0)
    assert speeds[115] == pytest.approx(math.sqrt(100.0 * 5.0), rel=0.1)  # in the hairpin
    assert speeds[50] == pytest.approx(95.0)  # mid-straight: 150 u from either hairpin
    assert np.all(np.diff(speeds[60:100]) <= 1e-9)  # braking into the hairpin
    assert speeds[95] < 60


# -- image tracks ----------------------------------------------------------------------------
EXAMPLES = TRACKS_DIR


def test_order_path_follows_a_drawn_loop_from_the_pose() -> None:
    angles = np.linspace(0, 2 * math.pi, 2000, endpoint=False)
    ring = np.concatenate(
        [(r * np.column_stack((np.cos(angles), np.sin(angles)))) for r in (99, 100, 101)]
    )
    pixels = np.round(ring + 500).astype(int)[np.random.default_rng(0).permutation(len(ring))]
    pose = (600.0, 500.0, math.pi / 2)  # on the ring at angle 0, heading +y
    points, closed = order_path(pixels.astype(float), pose, spacing=10.0)
    steps = np.hypot(*np.diff(points, axis=0).T)
    assert closed
    np.testing.assert_allclose(steps, 10.0, atol=1.5)  # [px] evenly spaced (chords)
    assert 600 < steps.sum() < 660  # once round: 628 px
    radius = np.hypot(*(points - 500).T)
    np.testing.assert_allclose(radius, 100, atol=2)
    turn = np.unwrap(np.arctan2(points[:, 1] - 500, points[:, 0] - 500))
    assert np.all(np.diff(turn) > 0)  # leaves along the heading: growing angles
    reverse, _ = order_path(pixels.astype(float), (600.0, 500.0, -math.pi / 2), spacing=10.0)
    assert np.all(np.diff(np.unwrap(np.arctan2(reverse[:, 1] - 500, reverse[:, 0] - 500))) < 0)


@pytest.mark.parametrize(
    ("model", "mean_error", "max_error"),  # [px]; the right lane is about 200 px wide
    [("kinematic", 8, 25), ("dynamic", 20, 80)],  # the dynamic car drives at 1200 px/s
)
def test_centerline_driver_follows_an_image_track_trajectory(
    model: str, mean_error: float, max_error: float
) -> None:
    env = gym.make(
        "tinyrace/TinyRace-v0", environment=EXAMPLES / "carolo_cup", car={"model": model}
    )
    driver = CenterlineDriver()
    _, info = env.reset(seed=1)
    driver.reset(env)
    errors = []
    for _ in range(300):
        _, _, terminated, truncated, info = env.step(driver.act(None, info))
        errors.append(info["cte"])
        assert not (terminated or truncated) and info["obstacles_hit"] == []
    assert np.mean(errors) < mean_error and max(errors) < max_error
    assert driver.route.y_down and driver.route.closed


def test_centerline_driver_needs_a_line_to_follow() -> None:
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment=EXAMPLES / "carolo_cup",
        reward_design={"cross_track_error": {"use_cte": False}},
    )
    env.reset(seed=0)
    with pytest.raises(ValueError, match="use_cte"):
        CenterlineDriver().reset(env)


@pytest.mark.parametrize(
    ("space", "action", "says"),
    [
        (spaces.Box(-1, 1, (3,)), [0.0, 0.5], "shape (2,)"),
        (spaces.Box(-1, 1, (3,)), [0.0, float("inf"), 0.0], "not finite"),
        (spaces.Box(-1, 1, (3,)), [0.0, 2.0, 0.0], "outside"),
        (spaces.Box(-1, 1, (3,)), "left", "expected numbers"),
        (spaces.Discrete(5), 7, "int in Discrete(5)"),
        (spaces.Discrete(5), True, "int in Discrete(5)"),
        (spaces.Discrete(5), 1.0, "int in Discrete(5)"),
    ],
)
def test_driver_output_is_checked(space, action, says):
    with pytest.raises(DriverError, match=re.escape(says)):
        check_action(action, space, "act() at step 3")
    check_action(space.sample(), space)  # a sample passes


def test_run_episode_shows_every_step_to_its_observer():
    class Count:
        def __init__(self):
            self.started, self.steps = 0, []

        def start(self, observation, info):
            self.started += 1

        def step(self, action, observation, reward, terminated, truncated, info):
            self.steps.append(reward)

    env = gym.make("tinyrace/CarRacing-v0")
    seen = Count()
    total, steps, _ = run_episode(env, ConstantDriver((0.0, 1.0, 0.0)), 0, 25, seen)
    assert seen.started == 1 and len(seen.steps) == steps == 25
    assert sum(seen.steps) == pytest.approx(total)
