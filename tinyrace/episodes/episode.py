"""One episode: a world with the track's static shapes and the cars, judged by rule parts.

The track says which rule parts its episodes are made of (``Track.rules``); the
``Course`` (made once per env) furnishes one world per track with what those parts need
and hands it to each new ``Episode``, which builds the parts for each car and turns the
world's contacts after a step into each car's ``StepFacts``. Nothing here depends on
the kind of track.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from typing import Any

from tinyrace.cars.registry import CarModel
from tinyrace.config import EnvConfig
from tinyrace.episodes.rules import Rule, rule_type
from tinyrace.episodes.start import grid_poses
from tinyrace.tracks.base import Pose, Track, TrackDraw
from tinyrace.world.facts import StepFacts
from tinyrace.world.snapshot import Snapshot
from tinyrace.world.world import World

GRASS_PARTS = ("tile_touches", "grass")  # parts whose tiles are also the wheels' road


class Episode:
    """One reset: the drawn track, its world with the cars in it, each car's rule parts."""

    def __init__(
        self,
        config: EnvConfig,
        draw: TrackDraw,
        world: World,
        car_model: CarModel,
        parts: tuple[str, ...],
        poses: Sequence[Pose],
    ):
        self.config = config
        self.draw = draw
        self.track: Track = draw.track
        self.track_index, self.spawn_index = draw.track_index, draw.spawn_index
        self.world = world
        world.remove_cars()  # the last episode's cars; the track's static shapes stay
        for pose in poses:
            world.add_car(car_model.build(world.space, pose, config.car, draw.track))
        rules = self.track.rules
        self.rules: list[list[Rule]] = [
            [rule_type(name)(self.track) for name in parts] for _ in world.cars
        ]
        self._reset_step = rules.reset_step
        self._labels = {
            "track": self.track_index,
            "spawn": self.spawn_index,
            "unit": self.track.unit,
        }
        self._info_labels = rules.info_labels

    @property
    def visit_order(self) -> list[int]:
        """The first car's tiles in the order first visited (pictures repaint them)."""
        for rule in self.rules[0]:
            order: list[int] | None = getattr(rule, "visit_order", None)
            if order is not None:
                return order  # the rule's own list, read as it grows
        return []

    def progress(self, car: int) -> int:
        """Tiles car ``car`` has visited (0 on a track without tiles)."""
        counts = (getattr(rule, "visited_count", 0) for rule in self.rules[car])
        return max(counts, default=0)

    def position(self, car: int) -> int:
        """Car ``car``'s place in the race by tiles visited: 1 + the cars further on."""
        return self.positions()[car]

    def positions(self) -> list[int]:
        """Every car's ``position``, each car's progress read once (a race's step asks
        for all of them)."""
        progress = [self.progress(car) for car in range(len(self.rules))]
        return [1 + sum(other > mine for other in progress) for mine in progress]

    def start(self, dt: float) -> list[StepFacts]:
        """The reset's step: one physics step with no action (CarRacing), or a look at the
        spawn (the cars do not move); either way the rules judge it. Each car's facts."""
        if self._reset_step:
            return self.step(dt)
        self.world.look(dt)
        return self._judge()

    def step(self, dt: float) -> list[StepFacts]:
        """The world's step with the controls the cars hold; each car's facts."""
        self.world.apply_forces(dt)
        return self.advance(dt)

    def advance(self, dt: float) -> list[StepFacts]:
        """The rest of a step whose forces are set: the world advanced, each car's facts
        (a parked car's rules judge no more: its facts stay empty)."""
        self.world.advance(dt)
        return self._judge()

    def park(self, car: int) -> None:
        """Take car ``car`` out of the race (it stays, standing, as an obstacle)."""
        self.world.park(car)

    def _judge(self) -> list[StepFacts]:
        world = self.world
        states, contacts, parked = world.states(), world.contacts, world.parked
        facts = [StepFacts() for _ in world.cars]
        for car, rules in enumerate(self.rules):
            if car in parked:
                continue
            for rule in rules:
                rule.judge(contacts[car], states[car], facts[car])
        return facts

    def info(self, snapshot: Snapshot, car: int = 0) -> dict[str, Any]:
        """Car ``car``'s info (``snapshot.cars[car]`` is that car): its pose and speed, the
        episode's labels, each rule's keys."""
        state = snapshot.cars[car]
        info: dict[str, Any] = {"pose": state.pose, "speed": state.speed}
        for label in self._info_labels:
            info[label] = self._labels[label]
        for rule in self.rules[car]:
            rule.info(info)
        return info


class Course:
    """What lasts across resets: one world per track, furnished once with what the track's
    rule parts need (a new track, as CarRacing draws every reset, gets a new world)."""

    def __init__(self, config: EnvConfig, car_model: CarModel):
        self.config = config
        self.car_model = car_model
        self.wheels = car_model.wheels  # its wheels feel the road's tiles (grip, grass)
        self._worlds: weakref.WeakKeyDictionary[Track, World] = weakref.WeakKeyDictionary()

    def new_episode(self, draw: TrackDraw, poses: Sequence[Pose] | None = None) -> Episode:
        """An episode on ``draw``'s track with a car at each of ``poses`` (by default the
        race's start grid: the spawn for one car)."""
        track = draw.track
        world = self._worlds.get(track)
        if world is None:
            world = self._worlds[track] = self.furnish(track)
        if poses is None:
            poses = self.grid(draw)
        return Episode(self.config, draw, world, self.car_model, self.parts(track), poses)

    def grid(self, draw: TrackDraw) -> list[Pose]:
        """The start grid behind ``draw``'s spawn (``race`` knobs; in car lengths and widths)."""
        race = self.config.race
        if race.num_agents == 1:
            return [draw.spawn]
        size = self.car_size(draw)
        return grid_poses(
            draw.track, draw.spawn, race.num_agents, size, race.grid_spacing, race.grid_offset
        )

    def car_size(self, draw: TrackDraw) -> tuple[float, float]:
        """(length, width) [track units] of the car model on ``draw``'s track: one built in a
        scratch world and read."""
        scratch = World()
        car = self.car_model.build(scratch.space, draw.spawn, self.config.car, draw.track)
        return car.state().footprint

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_worlds": list(self._worlds.items())}  # weak refs don't pickle

    def __setstate__(self, state: dict[str, Any]) -> None:
        worlds = state.pop("_worlds")
        self.__dict__.update(state)
        self._worlds = weakref.WeakKeyDictionary(worlds)

    def parts(self, track: Track) -> tuple[str, ...]:
        """The track's rule parts that apply to this car (grass only under wheels)."""
        return tuple(name for name in track.rules.parts if name != "grass" or self.wheels)

    def furnish(self, track: Track) -> World:
        """A world holding what the track's rule parts need (tiles, cells, walls, cones)."""
        parts = self.parts(track)
        on_tiles = any(name in GRASS_PARTS for name in parts)
        world = World(grass_off_tiles=on_tiles and track.off_road_friction < 1.0)
        for name in parts:
            rule_type(name).furnish(world, track)
        return world
