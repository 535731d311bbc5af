"""RaceEnv: the cars of one episode as PettingZoo agents, stepped together.

The env builds its parts as a ``TinyRaceEnv`` does (one config: track, rewards) with the
cars of ``race`` in the world (``race.cars``: each its own id, car model, sensors), and
gives every car a seat: its actions, its own sensors (riding on that car:
``Snapshot.seen_from``), running score, reward terms and end. A car whose episode ends
leaves ``agents``: after its last lap (``race.laps``) it is taken off the track (it stands
where it finished and nothing meets it, so that it does not block the line); out of
bounds, on an obstacle or in a collision that ends it, it is parked where it stands, an
obstacle the others still meet. The episode ends when every car is out or at
``sim.step_limit`` (all truncated).

Rewards, scores and ends per car are the episode's (``tinyrace.episodes.episode``), which
steps and judges every car at once; with ``race.tile_reward: first`` a tile pays only the
first car to visit it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from pettingzoo import ParallelEnv

from tinyrace.actions import ActionSpec
from tinyrace.config import car_names
from tinyrace.env import TinyRaceEnv
from tinyrace.episodes.episode import Episode
from tinyrace.errors import ConfigError, Problem, shown
from tinyrace.race.checks import race_with_cars, read_actions, reset_options
from tinyrace.sensors.base import Sensor
from tinyrace.world.snapshot import Snapshot

ACTIONS_SOURCE = "<step actions>"


class UnknownAgent(KeyError):
    """An agent id the race does not have: a KeyError (as a dict of agents gives) whose text
    lists the agents."""

    def __init__(self, agent: object, agents: list[str]):
        super().__init__(agent)
        self.agent = agent
        self.text = f"no agent {shown(agent)}; the agents are {', '.join(agents)}"

    def __str__(self) -> str:
        return self.text


@dataclass
class Seat:
    """What the env keeps for one car: its actions, sensors and observation space."""

    actions: ActionSpec
    sensors: list[Sensor]
    observation_space: spaces.Space[Any]
    box_camera: str | None  # ``observation: box``: the id of its one camera


class RaceEnv(ParallelEnv):  # type: ignore[misc]  # pettingzoo ships no type information
    """Cars on one tinyrace track, as a PettingZoo ParallelEnv.

    ## Agents
    The ids of ``race.cars`` (default ``car_0`` .. ``car_{N-1}``), N = ``race.num_agents``
    (or the ``num_agents`` keyword), at most 16, in car order: car 0 first (the pole of the
    grid, ``race.start``).

    ## Spaces
    Per car: its car model's actions and its own sensors (``race.cars[i]``'s, else the
    shared ones), seen from that car; cars of different models or sensors have different
    spaces.

    ## Rewards, ends, infos
    Per car, as a ``TinyRaceEnv`` computes them for its one car; infos add ``car`` (the
    index), ``id``, ``position`` (place in the race: laps and tiles, 1 = leading; cars level
    share a place: every car is 1 at reset),
    ``cars_hit`` (the ids of the other cars it touched this step), ``lap_times`` ([s] of
    sim time, steps x dt, of each lap finished) and ``best_lap`` ([s], None before a lap).
    """

    metadata: dict[str, Any] = {  # noqa: RUF012
        "name": "tinyrace_race_v0",
        "render_modes": ["rgb_array"],
        "render_fps": 50,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        config: str | Path | Mapping[str, Any] | None = None,
        environment: str | Path | None = None,
        num_agents: int | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ):
        if num_agents is not None:  # race.num_agents too: the same number, or an error
            race = race_with_cars(overrides.get("race"), num_agents, f"num_agents={num_agents!r}")
            overrides = {**overrides, "race": race}
        self.core = core = TinyRaceEnv(config, environment, render_mode=render_mode, **overrides)
        self.render_mode = render_mode
        racers = core.course.racers
        # the configured ids (car_<i> by default): what pictures write beside the cars
        self.possible_agents = car_names(core.config)
        self.agents: list[str] = []
        self._index = {agent: i for i, agent in enumerate(self.possible_agents)}
        self.seats = [self._seat(i) for i in range(len(racers))]
        self._observation_spaces = {
            a: _copy(seat.observation_space)
            for a, seat in zip(self.possible_agents, self.seats, strict=True)
        }
        self._action_spaces = {
            a: _copy(seat.actions.space)
            for a, seat in zip(self.possible_agents, self.seats, strict=True)
        }

    def _seat(self, car: int) -> Seat:
        """Car ``car``'s seat: car 0 sits in the core env's; each other car gets its own
        sensors (its entry's or the shared ones) and its car model's actions."""
        core = self.core
        if car == 0:
            return Seat(core.action_spec, core.sensors, core.observation_space, core.box_camera)
        racer = core.course.racers[car]
        sensors = core.make_sensors(car)  # none configured: the track's default sensor
        box_camera = core.box_sensor(sensors, car)
        space: spaces.Space[Any]
        if box_camera is not None:
            space = sensors[0].space
        else:
            space = spaces.Dict({sensor.id: sensor.space for sensor in sensors})
        return Seat(racer.model.actions(racer.car.car), sensors, space, box_camera)

    # -- PettingZoo API ---------------------------------------------------------------------
    def observation_space(self, agent: str) -> spaces.Space[Any]:
        return self._space(self._observation_spaces, agent)

    def action_space(self, agent: str) -> spaces.Space[Any]:
        return self._space(self._action_spaces, agent)

    def _space(self, spaces_: dict[str, spaces.Space[Any]], agent: object) -> spaces.Space[Any]:
        """The agent's space (the same object each time); ``UnknownAgent`` for another id."""
        try:
            return spaces_[agent]  # type: ignore[index]  # any key: a list is refused below
        except (KeyError, TypeError):  # TypeError: an unhashable id (a list)
            raise UnknownAgent(agent, self.possible_agents) from None

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        core = self.core
        _, first_info = core.reset(seed=seed, options=reset_options(options))
        episode = core.episode
        assert episode is not None
        self.agents = list(self.possible_agents)
        snapshot = core.snapshot()
        for seat in self.seats[1:]:
            for sensor in seat.sensors:
                sensor.reset(core.layout)
        observations = {agent: self._observe(snapshot, i) for agent, i in self._live()}
        infos = {agent: self._info(snapshot, i, {}) for agent, i in self._live()}
        first = self.possible_agents[0]
        infos[first] = {**first_info, **infos[first]}
        return observations, infos

    def step(
        self, actions: Mapping[str, Any]
    ) -> tuple[dict[str, Any], dict[str, float], dict[str, bool], dict[str, bool], dict[str, Any]]:
        core = self.core
        episode = core.episode
        if episode is None:
            raise ResetNeeded("call reset() before step()")
        if not self.agents:
            raise ResetNeeded("the race is over (every car is done): call reset()")
        self._check_agents(actions)
        world = episode.world
        live = self._live()
        for i, controls in read_actions(self.seats, actions, live):
            world.control(controls, car=i)
        cars = episode.step()  # every car judged; a car out of the race: None
        rewards, terminations, truncations, infos = {}, {}, {}, {}
        snapshot = core.snapshot()
        observations = {agent: self._observe(snapshot, i) for agent, i in live}
        positions = episode.positions()  # once per step, not per car
        for agent, i in live:
            car = cars[i]
            assert car is not None  # a car in the race
            rewards[agent], terminations[agent] = car.reward, car.reason is not None
            truncations[agent] = car.truncated
            info = self._info(snapshot, i, car.terms, positions)
            if car.reason is not None:
                info["termination"] = car.reason
                info["lap_finished"] = car.reason == "lap_finished"
            infos[agent] = info
        for i, car in enumerate(cars):  # after the observations: they saw it still racing
            if car is not None and car.reason is not None:
                episode.leave(i, car.reason)
        self.agents = [a for a, _ in live if not (terminations[a] or truncations[a])]
        return observations, rewards, terminations, truncations, infos

    def render(self) -> np.ndarray | None:
        return self.core.render()

    def close(self) -> None:
        self.core.close()

    def state(self) -> np.ndarray:
        """Every car's (x, y, heading, speed), car by car."""
        cars = self.core.snapshot().cars
        return np.array([[*car.pose, car.speed] for car in cars], dtype=np.float64)

    # -- parts ------------------------------------------------------------------------------
    def _live(self) -> list[tuple[str, int]]:
        return [(agent, self._index[agent]) for agent in self.agents]

    def _check_agents(self, actions: Mapping[str, Any]) -> None:
        """Every live car has an action, and only they: a ConfigError names the others."""
        if not isinstance(actions, Mapping):
            allowed = f"expected a dict of actions keyed by agent ({', '.join(self.agents)})"
            raise ConfigError(Problem(ACTIONS_SOURCE, "", type(actions).__name__, allowed))
        missing = [agent for agent in self.agents if agent not in actions]
        extra = [agent for agent in actions if agent not in self.agents]
        problems = [
            Problem(ACTIONS_SOURCE, str(agent), None, "no action for this car, which races on")
            for agent in missing
        ] + [
            Problem(ACTIONS_SOURCE, str(agent), "an action", _not_racing(agent, self))
            for agent in extra
        ]
        if problems:
            raise ConfigError(problems)

    def _observe(self, snapshot: Snapshot, car: int) -> Any:
        core = self.core
        episode = core.episode
        assert episode is not None
        seen = replace(snapshot.seen_from(car), score=episode.scores[car])
        sensors = self.seats[car].sensors
        observation = {s.id: s.observe(seen, core.layout, core.np_random) for s in sensors}
        box_camera = self.seats[car].box_camera
        return observation if box_camera is None else observation[box_camera]

    def _info(
        self,
        snapshot: Snapshot,
        car: int,
        terms: dict[str, float],
        positions: list[int] | None = None,
    ) -> dict[str, Any]:
        episode = self.core.episode
        assert episode is not None
        info = episode.info(snapshot, car)
        info["reward_terms"] = terms
        info["car"] = car
        info["id"] = self.possible_agents[car]
        info.update(race_info(episode, car, self.possible_agents, self.core.dt, positions))
        return info


def race_info(
    episode: Episode, car: int, names: list[str], dt: float, positions: list[int] | None = None
) -> dict[str, Any]:
    """Car ``car``'s place in the race, the cars it touched this step (by name), its lap
    times and best lap [s] (``dt``: the step [s]; ``positions``: every car's place, when
    the caller read them already)."""
    laps = episode.lap_times(car, dt)
    return {
        "position": episode.position(car) if positions is None else positions[car],
        "cars_hit": [names[other] for other in episode.world.contacts[car].new_cars],
        "lap_times": laps,
        "best_lap": min(laps) if laps else None,
    }


def _not_racing(agent: object, env: RaceEnv) -> str:
    if agent in env.possible_agents:
        return "this car is out of the race: it takes no more actions"
    return f"no such car; the agents are {', '.join(env.possible_agents)}"


def _copy(space: spaces.Space[Any]) -> spaces.Space[Any]:
    """A car's own copy of a space (its own random generator for ``sample``)."""
    import copy

    return copy.deepcopy(space)
