"""Render modes and the picture itself, against CarRacing-v3 where it can be compared (point 8)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import DependencyNotInstalled

import tinyrace  # noqa: F401

PROCEDURAL_IDS = ["tinyrace/CarRacing-v0", "tinyrace/TinyRace-v0"]
IDLE = np.zeros(3, np.float32)


def red_mask(image: np.ndarray) -> np.ndarray:
    """The hull's red (204, 0, 0), not the kerbs' (255, 0, 0)."""
    r, g, b = (image[..., i].astype(int) for i in range(3))
    return (abs(r - 204) < 25) & (g < 60) & (b < 60)


@pytest.mark.parametrize("env_id", PROCEDURAL_IDS)
@pytest.mark.parametrize(
    ("mode", "shape"), [("rgb_array", (400, 600, 3)), ("state_pixels", (96, 96, 3))]
)
def test_render_modes_give_carracing_sizes(env_id: str, mode: str, shape: tuple) -> None:
    env = gym.make(env_id, render_mode=mode)
    observation, _ = env.reset(seed=0)
    frame = env.render()
    assert frame.shape == shape and frame.dtype == np.uint8
    assert observation.shape == (96, 96, 3) and observation.dtype == np.uint8
    if mode == "state_pixels":
        np.testing.assert_array_equal(frame, observation)
    reference = gym.make("CarRacing-v3", render_mode=mode)
    reference.reset(seed=0)
    assert reference.render().shape == shape
    reference.close()


@pytest.mark.parametrize("env_id", PROCEDURAL_IDS)
def test_render_without_a_mode_warns_and_returns_none(env_id: str) -> None:
    env = gym.make(env_id)
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert env.unwrapped.render() is None


def test_human_mode_opens_and_closes_a_window() -> None:
    script = (
        "import json, gymnasium as gym, numpy as np, tinyrace, pygame\n"
        "env = gym.make('tinyrace/CarRacing-v0', render_mode='human')\n"
        "env.reset(seed=0)\n"
        "returned = [env.step(np.zeros(3, np.float32))[0].shape for _ in range(60)]\n"
        "surface = pygame.display.get_surface()\n"
        "size, pixel = surface.get_size(), list(surface.get_at((500, 600)))[:3]\n"
        "rendered = env.render()\n"
        "env.close()\n"
        "print(json.dumps({'size': size, 'pixel': pixel, 'render': rendered,"
        " 'obs': returned[-1], 'open': pygame.display.get_init()}))\n"
    )
    environ = {**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=environ, timeout=60
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["size"] == [1000, 800]
    assert result["render"] is None and result["obs"] == [96, 96, 3]
    assert result["pixel"] == [204, 0, 0]  # the hull, at half width and a quarter up
    assert result["open"] is False


def test_human_mode_without_pygame_names_the_missing_package(monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "pygame", None)  # makes `import pygame` fail
    env = gym.make("tinyrace/CarRacing-v0", render_mode="human")
    with pytest.raises(DependencyNotInstalled, match="pygame"):
        env.reset(seed=0)


def test_observation_changes_as_the_car_moves() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    env.reset(seed=0)
    gas = np.array([0.0, 1.0, 0.0], np.float32)
    frames = [env.step(gas)[0] for _ in range(80)]
    view = slice(0, 84)  # above the dashboard
    assert np.abs(frames[79][view].astype(int) - frames[69][view]).mean() > 1
    # standing still (after the zoom-in), the picture does not change
    env.reset(seed=0)
    still = [env.step(IDLE)[0] for _ in range(60)]
    np.testing.assert_array_equal(still[-1], still[-2])


def reddish(image: np.ndarray) -> np.ndarray:
    """Red, or red blended with its surroundings: the 96x96 hull is one or two pixels wide."""
    r, g, b = (image[..., i].astype(int) for i in range(3))
    return (r > 120) & (r - np.maximum(g, b) > 90)


@pytest.mark.parametrize("env_id", ["tinyrace/CarRacing-v0", "CarRacing-v3"])
def test_zoom_in_during_the_first_second(env_id: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    hull = []  # hull pixels around the car's place in the 600x400 frame
    for _ in range(100):
        env.step(IDLE)  # the car stands still: only the zoom changes the picture
        hull.append(int(red_mask(env.render()[270:330, 280:320]).sum()))
    # zoom 0.9 -> 16.2 window px per u during the first second, then fixed
    assert hull[0] < 20 < hull[14] < hull[29] < hull[59]
    assert hull[59] > 400
    assert hull[99] == hull[59]
    env.close()


@pytest.mark.parametrize("env_id", ["tinyrace/CarRacing-v0", "CarRacing-v3"])
def test_car_is_drawn_at_the_same_place(env_id: str) -> None:
    """Half width, a quarter of the height from the bottom, whatever the car does."""
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    actions = [IDLE] * 60 + [np.array([0.0, 1.0, 0.0], np.float32)] * 60
    actions += [np.array([-0.6, 0.3, 0.0], np.float32)] * 40
    for i, action in enumerate(actions):
        observation, *_ = env.step(action)
        if i in (59, 119, 159):
            frame = env.render()
            assert red_mask(frame[302:306, 292:308]).all()  # 600x400: centre (300, 300)
            rows, cols = np.nonzero(reddish(observation[56:84, 36:60]))  # 96x96: (48, 72)
            assert len(rows) > 10
            assert abs(rows.mean() + 56 - 71.5) < 1.5 and abs(cols.mean() + 36 - 47.5) < 1.0
    env.close()


def test_dashboard_bar_is_at_the_bottom_like_carracing_v3() -> None:
    shots = {}
    for env_id in ("tinyrace/CarRacing-v0", "CarRacing-v3"):
        env = gym.make(env_id)
        env.reset(seed=0)
        for _ in range(60):
            observation, *_ = env.step(np.array([0.0, 1.0, 0.0], np.float32))
        shots[env_id] = observation
        env.close()
    for observation in shots.values():
        bar = observation[84:]  # bottom 5/40 of 96 rows
        assert (bar.max(axis=2) == 0).mean() > 0.8  # mostly black
        assert (bar.min(axis=2) > 200).any()  # the white speed bar (or the score)
        assert (observation[:84].max(axis=2) == 0).mean() < 0.01  # no black above
    ours, reference = (shots[k][84:].max(axis=2) > 0 for k in shots)
    assert (ours == reference).mean() > 0.85


def test_info_reports_json_friendly_values() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    _, info = env.reset(seed=0)
    json.dumps(info)  # plain floats and ints: loggable as they are


@pytest.mark.parametrize("env_id", ["tinyrace/CarRacing-v0", "CarRacing-v3"])
def test_skid_marks_in_the_video_but_not_in_the_observation(env_id: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(45):  # full gas from standstill spins the rear wheels: skid marks
        observation, *_ = env.step(np.array([0.0, 1.0, 0.0], np.float32))
    frame = env.render()
    below = frame[325:350, 280:320].max(axis=2)  # behind the car in the 600x400 frame
    assert (below < 40).sum() > 20  # dark lines on the grey road
    assert observation[78:84, 42:54].min() > 80  # the 96x96 view shows the plain road
    env.close()
