"""Driving a race: one driver per car, the one race loop (as ``drivers.run_episode`` is for
one car), and what a driver's ``reset(env)`` sees of its car.

A driver is the same object as for one car (``reset(env)``, ``act(observation, info)``): it
gets its car's observation and info, and at each reset a ``CarView`` of the race that shows
its own car as a ``TinyRaceEnv`` shows its one car: ``action_space``, ``action_spec`` (the
actions' kind), ``observation_space``, ``config`` (its car, cameras and sensors over the
race's sections), ``car_facts`` and ``car`` are its car's, its random seed is its car's own
(two random drivers drive differently), and the other attributes are the race's
``TinyRaceEnv`` (``dt``, ``track``, ``snapshot()``). A race may mix car models: each driver
speaks its own car's actions.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol, cast

import gymnasium as gym
import numpy as np

from tinyrace.drivers import USER_CODE_ERRORS, Driver, DriverError, check_action
from tinyrace.errors import one_line
from tinyrace.race.env import RaceEnv


class CarDriverError(DriverError):
    """A car's driver failed (it raised, or returned an action its car cannot take)."""

    def __init__(self, agent: str, message: str):
        super().__init__(message)
        self.agent = agent


class RaceObserver(Protocol):
    """Watches a race: the reset, then every step (the dicts of ``RaceEnv.step``)."""

    def start(self, observations: dict[str, Any], infos: dict[str, Any]) -> None: ...

    def step(
        self,
        actions: dict[str, Any],
        observations: dict[str, Any],
        rewards: dict[str, float],
        terminations: dict[str, bool],
        truncations: dict[str, bool],
        infos: dict[str, Any],
    ) -> None: ...


class CarView:
    """A race seen by one car's driver: that car's spaces, actions, config, facts, live car
    and seed, else the race's env."""

    def __init__(self, race: RaceEnv, agent: str, seed: int | None):
        core = race.core
        index = race.possible_agents.index(agent)
        self.agent = agent
        self.index = index
        self.action_space = race.action_space(agent)
        self.action_spec = race.seats[index].actions
        self.observation_space = race.observation_space(agent)
        self.config = core.car_config(index)
        self.car_facts = core.course.racers[index].model.describe(self.config)
        self.np_random_seed = car_seed(seed, index)
        self._core = core

    @property
    def unwrapped(self) -> CarView:
        return self

    @property
    def car(self) -> Any:
        """This car in the current episode's world (as ``TinyRaceEnv.car`` is car 0)."""
        return self._core.world.cars[self.index]

    def __getattr__(self, name: str) -> Any:
        return getattr(self._core, name)


def car_seed(seed: int | None, car: int) -> int:
    """Car ``car``'s seed in an episode reset with ``seed``: the seed itself for car 0, a
    seed of its own (drawn from both) for the others."""
    base = -1 if seed is None else int(seed)
    if car == 0:
        return base
    return int(np.random.SeedSequence([max(base, 0), car]).generate_state(1)[0])


def drive_race(
    race: RaceEnv,
    drivers: Mapping[str, Driver],
    seed: int | None = None,
    max_steps: int | None = None,
    observer: RaceObserver | None = None,
) -> int:
    """Drive one race (every car by its driver in ``drivers``) until every car is out, the
    race's step limit or ``max_steps``; returns the steps.

    Raises CarDriverError naming the car whose driver raised or returned a bad action.
    """
    observations, infos = race.reset(seed=seed)
    for agent in race.possible_agents:
        view = cast(gym.Env, CarView(race, agent, seed))
        _call(agent, drivers[agent].reset, "reset()", view)
    if observer is not None:
        observer.start(observations, infos)
    steps = 0
    while race.agents and (max_steps is None or steps < max_steps):
        actions = {}
        for agent in race.agents:
            what = f"act() at step {steps}"
            action = _call(agent, drivers[agent].act, what, observations[agent], infos[agent])
            try:
                check_action(action, race.action_space(agent), what)
            except DriverError as exc:
                raise CarDriverError(agent, str(exc)) from None
            actions[agent] = action
        observations, rewards, terminations, truncations, infos = race.step(actions)
        steps += 1
        if observer is not None:
            observer.step(actions, observations, rewards, terminations, truncations, infos)
    return steps


def _call(agent: str, method: Callable[..., Any], what: str, *args: Any) -> Any:
    try:
        return method(*args)
    except USER_CODE_ERRORS as exc:  # the driver is user code: its failure is its car's
        raise CarDriverError(agent, f"{what} raised {one_line(exc)}") from exc
