"""The one episode loop (a driver against an env) and the checks on what a driver returns."""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from typing import Any, Protocol

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tinyrace.drivers.base import Driver
from tinyrace.errors import one_line, shown

# What a driver's code may raise that is its failure, reported as the driver's: any
# Exception, and an exit (sys.exit, a generator's close) that would end the run silently.
# Ctrl-C (KeyboardInterrupt) and the run's own signals go through.
USER_CODE_ERRORS = (Exception, SystemExit, GeneratorExit)


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
    except USER_CODE_ERRORS as exc:  # the driver is user code: any failure is reported as its own
        raise DriverError(f"{what} raised {one_line(exc)}") from exc


class DriverArgumentError(DriverError):
    """A built-in driver's keyword argument out of its range, named as written in an
    experiment: ``driver_args.<name>``."""

    def __init__(self, name: str, value: object, allowed: str):
        super().__init__(f"{name}: got {shown(value)}; {allowed}")
        self.name, self.value, self.allowed = name, value, allowed


def number_argument(
    name: str,
    value: object,
    low: float | None = None,
    high: float | None = None,
    unit: str = "",
    above: bool = False,
) -> float:
    """``value`` as a finite float from ``low`` (above it when ``above``) to ``high`` (a
    bound of None: none), else DriverArgumentError naming ``name``."""
    real = isinstance(value, numbers.Real) and not isinstance(value, bool)
    number = float(value) if real else math.nan  # type: ignore[arg-type]
    fits = math.isfinite(number) and (high is None or number <= high)
    if fits and (low is None or number > low or (number == low and not above)):
        return number
    bounds = [f"{'>' if above else '>='} {low:g}"] if low is not None else []
    bounds += [f"<= {high:g}"] if high is not None else []
    allowed = f"expected a finite number {' and '.join(bounds)}".rstrip()
    raise DriverArgumentError(name, value, allowed + (f" [{unit}]" if unit else ""))


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
