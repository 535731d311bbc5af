"""Gymnasium's env checker and passive checker pass, with no warning, on everything shipped.

Every registered tinyrace id, every example track and every experiment in
configs/ (its env made from the experiment's env_kwargs, as ``tinyrace run`` does).
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.env import TinyRaceEnv
from tinyrace.examples import CONFIGS_DIR, TRACKS_DIR
from tinyrace.experiment import load_experiment

ROOT = Path(__file__).resolve().parents[1]
IDS = sorted(k for k in gym.registry if k.startswith("tinyrace/"))
TRACKS = sorted(p.parent for p in (TRACKS_DIR).glob("*/track.yaml"))
CONFIGS = sorted((CONFIGS_DIR).glob("*.yaml"))


@pytest.fixture(autouse=True)
def no_display(monkeypatch):
    """check_env also makes the env with render_mode="human": a window on a dummy display."""
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")


def test_what_is_checked_exists():
    assert IDS == ["tinyrace/CarRacing-v0", "tinyrace/TinyRace-v0"]
    assert len(TRACKS) >= 3 and len(CONFIGS) >= 7


def run_checker(make) -> list[warnings.WarningMessage]:
    """check_env (render and close checks included) on the env ``make`` returns."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = make()
        check_env(env.unwrapped)
        env.close()
    return caught


def run_passive(make) -> list[warnings.WarningMessage]:
    """gym.make's PassiveEnvChecker sees reset, steps and renders."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = make()
        assert "PassiveEnvChecker" in str(env)
        env.reset(seed=0)
        for _ in range(3):
            env.step(env.action_space.sample())
        assert env.render() is not None
        env.reset(seed=1)
        env.step(env.action_space.sample())
        env.close()
    return caught


def describe(caught: list[warnings.WarningMessage]) -> list[str]:
    return [f"{w.category.__name__} {w.filename}:{w.lineno}: {w.message}" for w in caught]


def with_spec(env: TinyRaceEnv, kwargs: dict) -> TinyRaceEnv:
    """Give a directly built env the spec gym.make would: check_env then also tries every
    render mode (it warns that it cannot, otherwise)."""
    spec = gym.spec("tinyrace/TinyRace-v0")
    env.spec = dataclasses.replace(spec, kwargs={**spec.kwargs, **kwargs})
    return env


@pytest.mark.parametrize("env_id", IDS)
def test_registered_ids(env_id):
    make = lambda: gym.make(env_id, render_mode="rgb_array")  # noqa: E731
    assert describe(run_checker(make)) == []
    assert describe(run_passive(make)) == []


@pytest.mark.parametrize("track", TRACKS, ids=lambda p: p.name)
def test_example_tracks(track):
    make = lambda: gym.make(  # noqa: E731
        "tinyrace/TinyRace-v0", environment=str(track), render_mode="rgb_array"
    )
    assert describe(run_checker(make)) == []
    assert describe(run_passive(make)) == []


@pytest.mark.parametrize("config", CONFIGS, ids=lambda p: p.stem)
def test_shipped_configs(config):
    kwargs = load_experiment(config).env_kwargs
    direct = lambda: with_spec(TinyRaceEnv(**kwargs, render_mode="rgb_array"), kwargs)  # noqa: E731
    assert describe(run_checker(direct)) == []
    make = lambda: gym.make("tinyrace/TinyRace-v0", **kwargs, render_mode="rgb_array")  # noqa: E731
    assert describe(run_passive(make)) == []


def test_the_checks_see_warnings():
    """A warning raised while stepping reaches run_passive's list: the checks can fail."""

    class Noisy(gym.Wrapper):
        def step(self, action):
            gym.logger.warn("noisy step")
            return super().step(action)

    noisy = lambda: Noisy(gym.make("tinyrace/CarRacing-v0", render_mode="rgb_array"))  # noqa: E731
    assert any("noisy step" in line for line in describe(run_passive(noisy)))
