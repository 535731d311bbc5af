"""Gymnasium's env checker and passive checker pass, with no warning, on everything shipped.

Every registered tinyrace id, every example track and every experiment in
configs/ (its env made from the experiment's env_kwargs, as ``tinyrace run`` does).
"""

from __future__ import annotations

import functools
import warnings
from pathlib import Path

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env
from shipped import CONFIGS, IDS, TRACKS, shipped_envs

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = shipped_envs()


# check_env also makes the env with render_mode="human": a window on a dummy display
pytestmark = pytest.mark.usefixtures("no_display")


def test_what_is_checked_exists():
    assert IDS == ["tinyrace/CarRacing-v0", "tinyrace/TinyRace-v0"]
    assert len(TRACKS) >= 3 and len(CONFIGS) >= 7
    assert len(SHIPPED) == len(IDS) + len(TRACKS) + len(CONFIGS)


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


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_check_env(name):
    """check_env and the passive checker on every registered id, example track and config."""
    make = functools.partial(SHIPPED[name], render_mode="rgb_array")
    assert describe(run_checker(make)) == []
    assert describe(run_passive(make)) == []


def test_the_checks_see_warnings():
    """A warning raised while stepping reaches run_passive's list: the checks can fail."""

    class Noisy(gym.Wrapper):
        def step(self, action):
            gym.logger.warn("noisy step")
            return super().step(action)

    noisy = lambda: Noisy(gym.make("tinyrace/CarRacing-v0", render_mode="rgb_array"))  # noqa: E731
    assert any("noisy step" in line for line in describe(run_passive(noisy)))
