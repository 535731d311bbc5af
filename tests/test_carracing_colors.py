"""Domain randomisation and ``reset(options={"randomize": ...})`` as CarRacing-v3 (point 9).

Colours are drawn from the env's generator before the track, as the reference does,
so the same seed gives the same colours and the same track in both.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401

DEFAULT_ROAD = (102, 102, 102)


def colours(env) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    unwrapped = env.unwrapped
    if hasattr(unwrapped, "course"):
        c = unwrapped.track_source.colors  # drawn per reset, before the track
        return c.road, c.background, c.grass
    return unwrapped.road_color, unwrapped.bg_color, unwrapped.grass_color


def tiles(env) -> np.ndarray:
    unwrapped = env.unwrapped
    if hasattr(unwrapped, "course"):
        return unwrapped.track.tiles
    kerb = {(255, 255, 255), (255, 0, 0)}
    roads = [v for v, c in unwrapped.road_poly if tuple(int(x) for x in c[:3]) not in kerb]
    return np.array(roads, float)


@pytest.fixture(scope="module")
def pair():
    ours = gym.make("tinyrace/CarRacing-v0", domain_randomize=True)
    reference = gym.make("CarRacing-v3", domain_randomize=True)
    yield ours, reference
    reference.close()


# a seeded reset, then unseeded resets with and without new colours
SEQUENCE = [
    {"seed": 3},
    {},
    {"options": {"randomize": False}},
    {"options": {"randomize": True}},
    {"seed": 11, "options": {"randomize": False}},
]


def test_colours_and_tracks_follow_carracing_v3_reset_by_reset(pair) -> None:
    ours, reference = pair
    for kwargs in SEQUENCE:
        ours.reset(**kwargs)
        reference.reset(**kwargs)
        for a, b in zip(colours(ours), colours(reference), strict=True):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
        np.testing.assert_allclose(tiles(ours), tiles(reference), rtol=0, atol=1e-6)


def test_randomised_colours_change_per_reset_unless_told_not_to() -> None:
    env = gym.make("tinyrace/CarRacing-v0", domain_randomize=True)
    env.reset(seed=0)
    first = [c.copy() for c in colours(env)]
    env.reset()
    second = [c.copy() for c in colours(env)]
    env.reset(options={"randomize": False})
    third = colours(env)
    assert not np.allclose(first[0], second[0])
    for a, b in zip(second, third, strict=True):
        np.testing.assert_array_equal(a, b)
    road, background, grass = second
    for colour in (road, background):
        assert colour.min() >= 0 and colour.max() <= 210
    assert sorted(np.round(grass - background, 9)) == [0, 0, 20]


def test_without_domain_randomize_the_options_are_ignored() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    observation, _ = env.reset(seed=4)
    again, _ = env.reset(seed=4, options={"randomize": True})
    np.testing.assert_array_equal(observation, again)
    np.testing.assert_array_equal(colours(env)[0], DEFAULT_ROAD)
    reference = gym.make("CarRacing-v3")
    reference.reset(seed=4, options={"randomize": True})
    np.testing.assert_array_equal(colours(reference)[0], DEFAULT_ROAD)
    reference.close()


def test_the_picture_shows_the_drawn_colours() -> None:
    env = gym.make("tinyrace/CarRacing-v0", domain_randomize=True)
    pictures = []
    for kwargs in ({"seed": 1}, {"seed": 2}):
        env.reset(**kwargs)
        for _ in range(60):  # past the zoom-in, standing on the start line
            observation, *_ = env.step(np.zeros(3, np.float32))
        road, background, _ = colours(env)
        ahead = observation[50, 48].astype(float)  # road just ahead of the car
        corner = observation[2, 2].astype(float)  # grass or background, far off the road
        assert np.abs(ahead - road).max() <= 6  # tiles add up to 0.02 * 255 of shade
        assert np.abs(corner - road).max() > 10
        pictures.append((ahead, background))
    assert np.abs(pictures[0][0] - pictures[1][0]).max() > 10
