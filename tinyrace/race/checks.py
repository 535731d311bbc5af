"""What a race env checks at its doors: its number of cars, the reset options and every
car's action.

The number of cars may come from two keywords (``num_agents=`` and ``race={"num_agents":
...}``, or ``opponents=`` and ``race=``): given twice, it must be the same number, else a
ConfigError names both (``race_with_cars``).

A bad value is refused before anything changes, and the error names the car: ``reset``'s
options must be a mapping (or None); ``step``'s actions are read car by car with the car's
own ``ActionSpec``, and an action it refuses raises Gymnasium's ``InvalidAction`` saying
which car sent it, what it was and the car's action space.
"""

from __future__ import annotations

import math
import numbers
import reprlib
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Protocol

import gymnasium as gym
import numpy as np
from gymnasium.error import InvalidAction

from tinyrace.actions import ActionSpec
from tinyrace.env_checks import KWARGS_SOURCE, RESET_OPTIONS, RESET_SOURCE
from tinyrace.errors import ConfigError, Problem, shown

_SHORT = reprlib.Repr()
_SHORT.maxstring, _SHORT.maxother, _SHORT.maxlist, _SHORT.maxtuple = 40, 40, 6, 6


class HasActions(Protocol):
    """A car's seat: what ``read_actions`` needs of it."""

    actions: ActionSpec


def race_with_cars(race: object, count: object, asked_by: str) -> object:
    """The ``race`` keyword with ``num_agents`` set to ``count``, the number of cars that
    ``asked_by`` (another keyword) asks for. A ``race`` that is no mapping is given back as it
    is (the config's checks name it); one whose own ``num_agents`` is another number is a
    ConfigError naming both."""
    if race is None:
        race = {}
    if not isinstance(race, Mapping):
        return race
    own = race.get("num_agents")
    if own is not None and not _same_number(own, count):
        value = float(count) if _number(count) else math.nan  # type: ignore[arg-type]
        number = shown(int(value) if value.is_integer() else count)
        allowed = (
            f"expected {number} or no race.num_agents: {asked_by} asks for {number} cars "
            "(give the number of cars once, or the same in both)"
        )
        raise ConfigError(Problem(KWARGS_SOURCE, "race.num_agents", own, allowed))
    return {**race, "num_agents": count}


def _number(value: object) -> bool:
    """A real number, numpy's included, that is no boolean."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _same_number(a: object, b: object) -> bool:
    """Whether ``a`` and ``b`` are the same number (2, 2.0 and np.int64(2) alike); the
    config's checks say what else is wrong with either."""
    return _number(a) and _number(b) and float(a) == float(b)  # type: ignore[arg-type]


def reset_options(options: object, owner: str = "RaceEnv") -> dict[str, Any] | None:
    """The reset options tinyrace knows; others are left out with a warning (PettingZoo's
    API test resets with an option no env knows). Anything but a mapping or None is a
    ConfigError."""
    if options is None:
        return None
    if not isinstance(options, Mapping):
        allowed = f"expected a dict of reset options ({', '.join(RESET_OPTIONS)}) or None"
        raise ConfigError(Problem(RESET_SOURCE, "", options, allowed))
    unknown = [key for key in options if key not in RESET_OPTIONS]
    if unknown:
        gym.logger.warn(f"{owner}.reset ignores unknown options {unknown}; known: {RESET_OPTIONS}")
    return {key: value for key, value in options.items() if key in RESET_OPTIONS}


def read_actions(
    seats: Sequence[HasActions], actions: Mapping[str, Any], live: Iterable[tuple[str, int]]
) -> list[tuple[int, tuple[float, ...]]]:
    """(car index, controls) of every live car, each action read by its car's spec; the
    first bad one raises ``InvalidAction`` naming its car (nothing is applied before)."""
    read = []
    for agent, car in live:
        spec = seats[car].actions
        read.append((car, car_action(spec, actions[agent], f"car {agent!r}")))
    return read


def car_action(spec: ActionSpec, action: object, who: str) -> tuple[float, ...]:
    """``spec.read(action)``; a refusal says ``who`` sent it (e.g. ``car 'car_1'``)."""
    try:
        return spec.read(action)
    except InvalidAction as exc:
        raise InvalidAction(f"{who}: {exc}") from None
    except (TypeError, ValueError, OverflowError) as exc:  # an object no array can hold
        raise InvalidAction(
            f"{who}: action {_short(action)} is not an action of {spec.space} ({exc})"
        ) from None


def _short(value: object) -> str:
    try:
        return _SHORT.repr(value)
    except Exception:  # a user object whose repr fails
        return f"<{type(value).__name__}>"
