"""The one episode loop (a driver against an env) and the checks on what a driver returns."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tinyrace.drivers.base import Driver
from tinyrace.errors import one_line


class DriverError(ValueError):
    """A driver failed: it raised, or returned an action its env cannot take."""


class EpisodeObserver(Protocol):
    """Watches an episode: the reset, then every step (it may raise to stop the episode)."""

    def start(self, observation: Any, info: dict[str, Any]) -> None: ...

    def step(
        self,
        action: Any,
        observation: Any,
        reward: float,
        terminated: bool,
        truncated: bool,
        info: dict[str, Any],
    ) -> None: ...


def run_episode(
    env: gym.Env,
    driver: Driver,
    seed: int | None = None,
    max_steps: int | None = None,
    observer: EpisodeObserver | None = None,
) -> tuple[float, int, dict[str, Any]]:
    """Drive one episode; returns (return, steps, last info).

    Raises DriverError when the driver raises or returns an action outside the env's space.
    """
    observation, info = env.reset(seed=seed)
    _call(driver.reset, "reset()", env)
    if observer is not None:
        observer.start(observation, info)
    total, steps = 0.0, 0
    while max_steps is None or steps < max_steps:
        action = _call(driver.act, f"act() at step {steps}", observation, info)
        check_action(action, env.action_space, f"act() at step {steps}")
        observation, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        steps += 1
        if observer is not None:
            observer.step(action, observation, float(reward), terminated, truncated, info)
        if terminated or truncated:
            break
    return total, steps, info


def _call(method: Callable[..., Any], what: str, *args: Any) -> Any:
    try:
        return method(*args)
    except Exception as exc:  # the driver is user code: any failure is reported as its own
        raise DriverError(f"{what} raised {one_line(exc)}") from exc


def check_action(action: Any, space: spaces.Space[Any], what: str = "the action") -> None:
    """Raise DriverError unless ``action`` is a finite action inside ``space``."""
    if isinstance(space, spaces.Discrete):
        valid = isinstance(action, (int, np.integer)) and not isinstance(action, bool)
        if not valid or not space.contains(np.int64(action)):
            raise DriverError(f"{what} returned {action!r}; expected an int in {space}")
        return
    try:
        values = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise DriverError(f"{what} returned {_short(action)}; expected numbers") from None
    if values.shape != space.shape:
        raise DriverError(
            f"{what} returned shape {values.shape}; expected shape {space.shape} of {space}"
        )
    if not np.isfinite(values).all():
        raise DriverError(f"{what} returned {values.tolist()}, not finite; expected {space}")
    if not space.contains(values.astype(space.dtype)):
        raise DriverError(f"{what} returned {values.tolist()}, outside {space}")


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
