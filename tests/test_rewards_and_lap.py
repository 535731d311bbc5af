"""Rewards and the end of an episode, as CarRacing-v3 (minus its lap bug #1269) (point 5)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401
from tinyrace.drivers import CenterlineDriver

PROCEDURAL_IDS = ["tinyrace/CarRacing-v0", "tinyrace/TinyRace-v0"]
IDLE = np.zeros(3, np.float32)
GAS = np.array([0.0, 1.0, 0.0], np.float32)


@pytest.mark.parametrize("env_id", PROCEDURAL_IDS)
def test_reset_takes_one_step_and_the_first_step_pays_for_it(env_id: str) -> None:
    env = gym.make(env_id)
    _, info = env.reset(seed=0)
    n = info["tiles_total"]
    # the car starts across tiles 0 and 1: the step taken by reset touched both
    assert info["tiles_visited"] == 2
    _, first, *_ = env.step(IDLE)
    _, second, *_ = env.step(IDLE)
    assert first == pytest.approx(-0.1 + 2 * 1000 / n)
    assert second == pytest.approx(-0.1)


def test_rewards_over_a_drive_add_up_to_tiles_and_time() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    _, info = env.reset(seed=1)
    driver = CenterlineDriver()
    driver.reset(env)
    n, total, before = info["tiles_total"], 0.0, info["tiles_visited"]
    for step in range(1, 301):
        _, reward, terminated, truncated, info = env.step(driver.act(None, info))
        total += reward
        if step > 1:  # every later step: -0.1 plus 1000/N per newly visited tile
            assert reward == pytest.approx(-0.1 + (info["tiles_visited"] - before) * 1000 / n)
        before = info["tiles_visited"]
        assert not (terminated or truncated)
    assert info["tiles_visited"] > 100
    assert total == pytest.approx(info["tiles_visited"] * 1000 / n - 0.1 * 300)


@pytest.mark.parametrize("seed", [0, 3])
def test_rewards_follow_carracing_v3_under_full_gas(seed: int) -> None:
    """Same tiles paid as the reference; tinyrace may pay a tile one step sooner (pymunk
    reports a contact in the step that makes it, Box2D in the step after)."""
    ours, reference = gym.make("tinyrace/CarRacing-v0"), gym.make("CarRacing-v3")
    ours.reset(seed=seed)
    reference.reset(seed=seed)
    a = np.cumsum([ours.step(GAS)[1] for _ in range(80)])
    b = np.cumsum([reference.step(GAS)[1] for _ in range(80)])
    tile = 1000 / len(ours.unwrapped.track.tiles)
    assert a[0] == pytest.approx(b[0])
    assert np.all(np.abs(a - b) <= tile + 1e-6)
    assert a[-1] == pytest.approx(b[-1]) and a[-1] > 10 * tile
    reference.close()


# -- leaving the playfield -------------------------------------------------------------------
def test_leaving_the_playfield_ends_with_minus_100() -> None:
    # the start point is at x ~ 220 u: a playfield of 230 u is left by turning right
    config = {"track": {"type": "procedural", "playfield": 230.0}}
    env = gym.make("tinyrace/TinyRace-v0", config=config)
    env.reset(seed=0)
    action = np.array([1.0, 1.0, 0.0], np.float32)
    steps, terminated = 0, False
    while not terminated and steps < 300:
        _, reward, terminated, truncated, info = env.step(action)
        steps += 1
    assert terminated and not truncated and steps < 300
    assert reward == -100
    assert info["lap_finished"] is False and info["termination"] == "out_of_bounds"
    x, y, _ = info["pose"]
    assert max(abs(x), abs(y)) > 230.0


# -- finishing a lap -------------------------------------------------------------------------
def test_centerline_driver_finishes_a_lap_by_the_rule() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    observation, info = env.reset(seed=0)
    driver = CenterlineDriver()
    driver.reset(env)
    total, steps, terminated, truncated = 0.0, 0, False, False
    while not (terminated or truncated):
        observation, reward, terminated, truncated, info = env.step(driver.act(observation, info))
        total += reward
        steps += 1
    assert terminated and not truncated and steps < 1000
    assert info["lap_finished"] is True and info["termination"] == "lap_finished"
    assert info["tiles_visited"] / info["tiles_total"] > 0.95
    assert total > 850


def drive_last_tiles(
    lap_complete_percent: float, back: int = 6, seed: int = 2
) -> tuple[np.ndarray, list]:
    """Put the car ``back`` points before the start and drive through tile 0 again.

    Tile 0 was visited by reset, so this is the return that Gymnasium issue #1269 misses.
    """
    env = gym.make("tinyrace/CarRacing-v0", lap_complete_percent=lap_complete_percent)
    env.reset(seed=seed)
    track, car = env.unwrapped.track, env.unwrapped.car
    car.body.position = tuple(track.centerline[-back])
    # the hull angle (the nose along the track): a quarter turn short of the travel direction
    car.body.angle = float(track.headings[-back]) - math.pi / 2
    infos = []
    for _ in range(60):
        _, reward, terminated, _, info = env.step(GAS)
        infos.append((reward, terminated, info))
        if terminated:
            break
    return track.centerline[[-1, 0, 1]], infos


def past(pose: tuple, points: np.ndarray) -> float:
    """[u] how far the car is ahead of points[1] along the track (points: -1, 0 and 1)."""
    direction = (points[2] - points[1]) / np.linalg.norm(points[2] - points[1])
    return float(np.dot(np.subtract(pose[:2], points[1]), direction))


def test_back_on_tile_0_after_enough_tiles_finishes_the_lap() -> None:
    start, infos = drive_last_tiles(lap_complete_percent=0.01)  # 2 + 6 of ~300 tiles: above 1%
    _, terminated, info = infos[-1]
    assert terminated and info["lap_finished"] is True
    assert info["tiles_visited"] < info["tiles_total"] / 10  # far from every tile
    # it ended as the nose (2.2 u ahead of the pose) reached tile 0, which ends at point 0
    tile_0 = np.linalg.norm(start[1] - start[0])
    assert -tile_0 - 2.5 < past(info["pose"], start) < -tile_0 + 0.5


def test_back_on_tile_0_with_too_few_tiles_does_not() -> None:
    start, infos = drive_last_tiles(lap_complete_percent=0.95)
    assert not any(terminated for _, terminated, _ in infos)
    assert infos[-1][2]["tiles_visited"] > 8  # it did drive through tile 0 and beyond
    assert past(infos[-1][2]["pose"], start) > 5  # [u] past the start line


def test_every_tile_visited_finishes_the_lap_whatever_the_percentage() -> None:
    env = gym.make("tinyrace/CarRacing-v0", lap_complete_percent=1.0)
    observation, info = env.reset(seed=8)
    driver = CenterlineDriver()
    driver.reset(env)
    for _ in range(1000):
        observation, _, terminated, truncated, info = env.step(driver.act(observation, info))
        if terminated or truncated:
            break
    assert terminated and info["lap_finished"] is True
    assert info["tiles_visited"] == info["tiles_total"]
