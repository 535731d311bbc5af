"""The env as PPO trains on it: made in a worker process too, its exceptions reported as
an episode end (the worker stays alive, the trainer raises them), a dict's nested entries
flattened (SB3 takes no nested dicts: ``tinyrace.flat_observations``)."""

from __future__ import annotations

import multiprocessing
import signal
from typing import Any, SupportsFloat

import gymnasium as gym
from gymnasium import spaces

from tinyrace.flat_observations import flat_observation, flat_space, nested_entries

FAILED = "tinyrace_env_error"  # the info key by which a worker's env reports its exception


class EnvFailed(RuntimeError):
    """An env raised while training or evaluating (in this process or a worker's)."""


def _make(env_id: str, kwargs: dict[str, Any]) -> gym.Env[Any, Any]:
    """One env (module level, so that worker processes unpickle it and import tinyrace)."""
    import tinyrace  # noqa: F401  (registers the ids in a worker process)

    if multiprocessing.parent_process() is not None:  # a worker: Ctrl-C is the trainer's
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    env: gym.Env[Any, Any] = Reporting(gym.make(env_id, **kwargs))
    if isinstance(env.observation_space, spaces.Dict) and nested_entries(env.observation_space):
        env = FlatEntries(env)
    return env


class Reporting(gym.Wrapper[Any, Any, Any, Any]):
    """An env whose exceptions become an episode end with ``info[FAILED]`` (the error as
    text), so that a worker process stays alive and the trainer ends the run with it."""

    def __init__(self, env: gym.Env[Any, Any]):
        super().__init__(env)
        self._last: Any = None

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        try:
            observation, info = self.env.reset(**kwargs)
        except Exception as exc:  # reported to the trainer, which raises it
            return self._stand_in(), {FAILED: _described(exc)}
        self._last = observation
        return observation, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        try:
            observation, reward, terminated, truncated, info = self.env.step(action)
        except Exception as exc:  # reported to the trainer, which raises it
            return self._stand_in(), 0.0, True, False, {FAILED: _described(exc)}
        self._last = observation
        return observation, reward, terminated, truncated, info

    def _stand_in(self) -> Any:
        return self._last if self._last is not None else self.observation_space.sample()


def _described(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def raise_failure(infos: Any) -> None:
    """Raise EnvFailed when one env's info (a sequence of them) reports an exception."""
    for info in infos or ():
        if isinstance(info, dict) and FAILED in info:
            raise EnvFailed(f"an env raised during training: {info[FAILED]}")


class FlatEntries(gym.ObservationWrapper[Any, Any, Any]):
    """A dict observation whose entries are all arrays (``flat_space``)."""

    def __init__(self, env: gym.Env[Any, Any]):
        super().__init__(env)
        space = env.observation_space
        assert isinstance(space, spaces.Dict)
        self._nested = nested_entries(space)
        self.observation_space = flat_space(space)

    def observation(self, observation: dict[str, Any]) -> dict[str, Any]:
        return flat_observation(self._nested, observation)
