"""Who drives each car of a race: the experiment's ``drivers`` (by car name or index),
and its ``driver`` for every car not listed there."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from tinyrace.config.experiment import ExperimentConfig
from tinyrace.errors import Problem

ENTRY_KEYS = ("driver", "driver_args")  # a car's entry as a mapping


@dataclass(frozen=True)
class CarDriver:
    """One car's driver: the spec and arguments, and the key of the file that set them."""

    agent: str  # the car's name (RaceEnv.possible_agents)
    spec: str  # random | constant | centerline | module:callable
    args: dict[str, Any] = field(default_factory=dict)
    key: str = "driver"  # drivers.<name>, or driver for a car the drivers do not list


def car_drivers(
    config: ExperimentConfig, agents: Sequence[str], source: str
) -> tuple[list[CarDriver], list[Problem]]:
    """One driver per car of ``agents``, and the problems of ``config.drivers`` (a key that
    names no car, a car named twice, an entry that is neither a driver nor
    {driver, driver_args}); the specs themselves are checked by ``load.driver_problems``."""
    problems: list[Problem] = []
    chosen: dict[str, CarDriver] = {}
    for key, entry in config.drivers.items():
        where = f"drivers.{key}"
        agent = agent_of(key, agents)
        if agent is None:
            allowed = (
                f"expected a car of the race: {', '.join(agents)} "
                f"(or its index, 0 to {len(agents) - 1})"
            )
            problems.append(Problem(source, where, key, allowed))
            continue
        if agent in chosen:
            allowed = f"expected each car once; {chosen[agent].key} names car {agent} too"
            problems.append(Problem(source, where, key, allowed))
            continue
        parsed = _entry(entry, agent, where, source)
        if isinstance(parsed, Problem):
            problems.append(parsed)
        else:
            chosen[agent] = parsed
    drivers = [
        chosen.get(agent) or CarDriver(agent, config.driver, dict(config.driver_args))
        for agent in agents
    ]
    return drivers, problems


def agent_of(key: object, agents: Sequence[str]) -> str | None:
    """The car a ``drivers`` key names: a car's name, or its index (a number or digits)."""
    if isinstance(key, str) and key in agents:
        return key
    if isinstance(key, bool):
        return None
    if isinstance(key, str) and key.isdigit() and len(key) < 4:
        key = int(key)
    if isinstance(key, int) and 0 <= key < len(agents):
        return agents[key]
    return None


def _entry(entry: object, agent: str, where: str, source: str) -> CarDriver | Problem:
    """A car's entry: a driver spec, or {driver: spec, driver_args: {...}}."""
    if isinstance(entry, str):
        return CarDriver(agent, entry, {}, where)
    expected = f"car {agent}'s driver: expected a driver name, module:callable or " + (
        "{driver: ..., driver_args: {...}}"
    )
    if not isinstance(entry, Mapping):
        return Problem(source, where, entry, expected)
    unknown = [k for k in entry if k not in ENTRY_KEYS]
    if unknown:
        return Problem(source, f"{where}.{unknown[0]}", unknown[0], expected)
    spec, args = entry.get("driver"), entry.get("driver_args", {})
    if not isinstance(spec, str):
        return Problem(source, f"{where}.driver", spec, expected)
    if not isinstance(args, Mapping) or not all(isinstance(k, str) for k in args):
        allowed = f"car {agent}'s driver_args: expected a mapping of keyword arguments"
        return Problem(source, f"{where}.driver_args", args, allowed)
    return CarDriver(agent, spec, dict(args), f"{where}.driver")
