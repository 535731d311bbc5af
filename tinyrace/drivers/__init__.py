"""Built-in drivers: policies that need no training, for baselines, demos and tests.

A driver is set up once per episode with ``reset(env)`` (after ``env.reset``)
and then asked for one action per step with ``act(observation, info)``. Drivers
speak the env's own action space: they think in CarRacing's controls
``(steer, gas, brake)`` (steer -1 full left .. +1 full right) and convert to a
Box, or to the nearest action of CarRacing's Discrete(5).

>>> import gymnasium as gym, tinyrace
>>> from tinyrace.drivers import make_driver
>>> env = gym.make("tinyrace/CarRacing-v0")
>>> driver = make_driver("centerline")
>>> observation, info = env.reset(seed=0)
>>> driver.reset(env)
>>> observation, reward, terminated, truncated, info = env.step(driver.act(observation, info))
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

import gymnasium as gym

from tinyrace.drivers.base import (
    ActionAdapter,
    ConstantDriver,
    Controls,
    DiscreteChooser,
    Driver,
    RandomDriver,
)
from tinyrace.drivers.centerline import CenterlineDriver, Route, order_path, route_of, speed_profile
from tinyrace.drivers.loop import (
    USER_CODE_ERRORS,
    DriverArgumentError,
    DriverError,
    EpisodeObserver,
    check_action,
    run_episode,
)
from tinyrace.errors import did_you_mean, one_line

__all__ = [
    "DRIVERS",
    "USER_CODE_ERRORS",
    "ActionAdapter",
    "CenterlineDriver",
    "ConstantDriver",
    "Controls",
    "DiscreteChooser",
    "Driver",
    "DriverArgumentError",
    "DriverError",
    "EpisodeObserver",
    "RandomDriver",
    "Route",
    "check_action",
    "load_driver",
    "make_driver",
    "order_path",
    "route_of",
    "run_episode",
    "speed_profile",
]

DriverFactory = Callable[..., Driver]

DRIVERS: dict[str, DriverFactory] = {
    "random": RandomDriver,
    "constant": ConstantDriver,
    "centerline": CenterlineDriver,
}


def make_driver(name: str, **kwargs: Any) -> Driver:
    """A driver by registry name; raises ValueError listing the valid names."""
    factory = DRIVERS.get(name)
    if factory is None:
        raise ValueError(unknown_driver(name))
    return factory(**kwargs)


def unknown_driver(name: str) -> str:
    """The message for a driver name that is not registered: the closest name, then all."""
    hint = did_you_mean(name, DRIVERS)
    return f"unknown driver {name!r}; {hint}valid drivers: {', '.join(sorted(DRIVERS))}"


class PolicyDriver:
    """Wraps a plain ``policy(observation, info) -> action`` function as a Driver."""

    def __init__(self, policy: Callable[[Any, dict[str, Any]], Any]):
        self.policy = policy

    def reset(self, env: gym.Env) -> None:
        """A plain policy keeps no state between episodes."""

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        return self.policy(observation, info)


def load_driver(spec: str, **kwargs: Any) -> Driver:
    """A built-in driver by name, or ``module:callable``: a factory called with ``kwargs``
    that returns a Driver (``reset(env)``, ``act(observation, info)``) or a policy function.

    Raises ValueError (unknown name, import failure, wrong return) or DriverError (the
    factory raised, e.g. a TypeError for ``kwargs`` it does not take).
    """
    factory = _factory(spec)
    try:
        made = factory(**kwargs)
    except DriverArgumentError:  # a built-in driver's argument: named as driver_args.<name>
        raise
    except USER_CODE_ERRORS as exc:  # user code and user arguments: report, do not crash
        raise DriverError(f"{spec} with driver_args {kwargs} raised {one_line(exc)}") from exc
    if hasattr(made, "act"):
        return made
    if callable(made):
        return PolicyDriver(made)
    raise ValueError(f"{spec!r} returned {type(made).__name__}, not a driver or a policy function")


def _factory(spec: str) -> DriverFactory:
    """The registry entry of a name, or the ``module:callable`` imported."""
    if ":" not in spec:
        if spec not in DRIVERS:
            raise ValueError(unknown_driver(spec))
        return DRIVERS[spec]
    module_name, _, attribute = spec.partition(":")
    try:
        factory: Callable[..., Driver] = getattr(importlib.import_module(module_name), attribute)
        return factory
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"cannot import {spec!r} ({one_line(exc)})") from None
