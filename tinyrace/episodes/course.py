"""What lasts across an env's resets: the ``Course`` keeps one furnished world per track
and starts each episode on it, its cars where ``race.start`` puts them (``start.py``: the
grid; ``start_pose.py``: a car must fit its start)."""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from typing import Any

import numpy as np

from tinyrace.config import EnvConfig
from tinyrace.episodes.episode import Episode, Racer, Start
from tinyrace.episodes.rules import rule_type
from tinyrace.episodes.start import grid_poses, random_poses
from tinyrace.episodes.start_pose import grid_check
from tinyrace.errors import ConfigError, Problem
from tinyrace.tracks.base import Pose, Track, TrackDraw
from tinyrace.world.world import World

RESET_SOURCE = "<reset options>"
RANDOM_ATTEMPTS = 50  # random starts drawn before a race is refused for want of room


class Course:
    """What lasts across resets: one world per track, furnished once with what the track's
    rule parts need (a new track, as CarRacing draws every reset, gets a new world)."""

    def __init__(self, config: EnvConfig, racers: Sequence[Racer], source: str = "<config>"):
        self.config = config
        self.racers = tuple(racers)
        self.source = source  # where the config came from (problems with its start poses)
        self.car_model = racers[0].model
        # a car's wheels feel the road's tiles (grip, grass)
        self.wheels = any(racer.model.wheels for racer in racers)
        self._worlds: weakref.WeakKeyDictionary[Track, World] = weakref.WeakKeyDictionary()

    def new_episode(
        self,
        draw: TrackDraw,
        poses: Sequence[Pose] | None = None,
        rng: np.random.Generator | None = None,
    ) -> Episode:
        """An episode on ``draw``'s track with a car at each of ``poses`` (a reset's option),
        else where ``race.start`` puts them (the spawn for one car); ``rng`` draws a random
        start. A ConfigError names a car that would start on another, a wall or a cone."""
        track = draw.track
        world = self._worlds.get(track)
        if world is None:
            world = self._worlds[track] = self.furnish(track)
        parts = [self.parts(track, racer) for racer in self.racers]
        if poses is not None:
            paths = [f"poses[{i}]" for i in range(len(poses))]
            start = Start(list(poses), RESET_SOURCE, paths)
            return Episode(self.config, draw, world, self.racers, parts, start)
        if self.config.race.start != "random":
            return Episode(self.config, draw, world, self.racers, parts, self.start(draw))
        for attempt in range(RANDOM_ATTEMPTS):  # until every car is clear of walls and cones
            try:
                start = self.start(draw, rng)
                return Episode(self.config, draw, world, self.racers, parts, start)
            except ConfigError:
                if attempt == RANDOM_ATTEMPTS - 1:
                    raise
        raise AssertionError("unreachable")

    def start(self, draw: TrackDraw, rng: np.random.Generator | None = None) -> Start:
        """The cars' start poses on ``draw``'s track by ``race.start`` (``race`` knobs)."""
        race, count = self.config.race, len(self.racers)
        paths = [self._car_key(i) for i in range(count)]
        if count == 1 and race.start != "poses":
            return Start([draw.spawn], self.source, paths)
        size = self.car_size(draw)
        if race.start == "poses":
            paths = [f"race.poses[{i}]" for i in range(count)]
            return Start(list(race.poses), self.source, paths)
        if race.start == "random":
            if rng is None:
                rng = np.random.default_rng(0)  # the env passes its np_random
            try:
                poses = random_poses(
                    draw.track, draw.spawn, count, size, race.grid_spacing, race.grid_offset, rng
                )
            except ValueError as exc:
                raise ConfigError(self._no_room(str(exc))) from None
            return Start(poses, self.source, paths)
        cars = [(racer.model, racer.car.car) for racer in self.racers]
        fits = grid_check(draw.track, cars)  # each place clear, else the next one
        key = tuple((model.name, car) for model, car in cars)  # the grid kept per track
        spacing, offset = race.grid_spacing, race.grid_offset
        try:
            poses = grid_poses(draw.track, draw.spawn, count, size, spacing, offset, fits, key)
        except ValueError as exc:
            allowed = f"expected a smaller race.grid_spacing or fewer cars: {exc}"
            problem = Problem(self.source, "race.grid_spacing", race.grid_spacing, allowed)
            raise ConfigError(problem) from None
        hint = (
            f" (grid places behind spawn {draw.spawn_index} of track {draw.track_index}: fewer "
            "cars, a smaller race.grid_spacing or race.grid_offset make room)"
        )
        return Start(poses, self.source, paths, hint, f"{count} cars")

    def _car_key(self, car: int) -> str:
        """The key that names car ``car`` in the config."""
        return f"race.cars[{car}]" if self.config.race.cars else "race.num_agents"

    def _no_room(self, why: str) -> Problem:
        race = self.config.race
        allowed = f"expected fewer cars or a smaller race.grid_spacing: {why}"
        return Problem(self.source, self._car_key(len(self.racers) - 1), race.num_agents, allowed)

    def check_fixed_starts(self, tracks: Sequence[Track]) -> list[Problem]:
        """Every problem of the start grid (or the config's poses) on each fixed track, at
        each spawn: a car on another, a wall or a cone, or outside the track."""
        if len(self.racers) == 1:
            return []  # one car: ``start_fits``
        problems: list[Problem] = []
        for index, track in enumerate(tracks):
            for spawn_index in range(len(track.spawns)):
                draw = TrackDraw(track, index, spawn_index)
                try:
                    if self.config.race.start == "random":  # room on the line; drawn per reset
                        self.start(draw, np.random.default_rng(0))
                    else:
                        self.new_episode(draw)
                except ConfigError as exc:
                    problems += [p for p in exc.problems if p not in problems]
        return problems

    def car_size(self, draw: TrackDraw) -> tuple[float, float]:
        """(length, width) [track units] of the largest car on ``draw``'s track: each model
        built in a scratch world and read."""
        scratch = World()
        sizes = [
            racer.model.build(scratch.space, draw.spawn, racer.car.car, draw.track)
            .state()
            .footprint
            for racer in self.racers
        ]
        return max(size[0] for size in sizes), max(size[1] for size in sizes)

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_worlds": list(self._worlds.items())}  # weak refs don't pickle

    def __setstate__(self, state: dict[str, Any]) -> None:
        worlds = state.pop("_worlds")
        self.__dict__.update(state)
        self._worlds = weakref.WeakKeyDictionary(worlds)

    def parts(self, track: Track, racer: Racer | None = None) -> tuple[str, ...]:
        """The track's rule parts and the config's ``rules:`` entries' that apply to
        ``racer``'s car (a wheels-only part only to a car with wheels; without a racer: to
        any car of the race)."""
        wheels = self.wheels if racer is None else racer.model.wheels
        named = (*track.rules.parts, *(entry.type for entry in self.config.rules))
        return tuple(name for name in named if wheels or not rule_type(name).wheels_only)

    def furnish(self, track: Track) -> World:
        """A world holding what the track's rule parts need (tiles, cells, walls, cones)."""
        parts = self.parts(track)
        on_tiles = any(rule_type(name).road_tiles for name in parts)
        world = World(grass_off_tiles=on_tiles and track.off_road_friction < 1.0)
        for name in parts:
            rule_type(name).furnish(world, track)
        return world
