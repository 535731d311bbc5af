"""One episode: a world with the track's static shapes and the cars, judged by rule parts.

The track says which rule parts its episodes are made of (``Track.rules``); the
``Course`` (``course.py``, made once per env) furnishes one world per track with what those
parts need and hands it to each new ``Episode``, which builds the parts for each car and
turns the world's contacts after a step into each car's ``StepFacts``. Nothing here depends on
the kind of track.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from tinyrace.cars.registry import CarModel
from tinyrace.config import EnvConfig, RaceCar
from tinyrace.episodes.rules import Rule, rule_type
from tinyrace.episodes.start_pose import placement_problems
from tinyrace.errors import ConfigError
from tinyrace.tracks.base import Pose, Track, TrackDraw
from tinyrace.world.facts import StepFacts
from tinyrace.world.snapshot import Snapshot
from tinyrace.world.world import World


@dataclass(frozen=True)
class Racer:
    """One car of the race: its config (id, car, colour, sensors) and its car model."""

    car: RaceCar
    model: CarModel

    @property
    def id(self) -> str:
        return self.car.id


@dataclass(frozen=True)
class Start:
    """Where the cars of an episode start, and the keys problems with them name."""

    poses: list[Pose]
    source: str
    paths: list[str]  # per car: the key its pose came from
    hint: str = ""  # how to make room, said after each problem
    value: object = None  # the value problems show (None: each car's pose)


class Episode:
    """One reset: the drawn track, its world with the cars in it, each car's rule parts,
    laps and lap times."""

    def __init__(
        self,
        config: EnvConfig,
        draw: TrackDraw,
        world: World,
        racers: Sequence[Racer],
        parts: Sequence[tuple[str, ...]],
        start: Start,
    ):
        self.config = config
        self.draw = draw
        self.track: Track = draw.track
        self.track_index, self.spawn_index = draw.track_index, draw.spawn_index
        self.world = world
        world.remove_cars()  # the last episode's cars; the track's static shapes stay
        for racer, pose in zip(racers, start.poses, strict=True):
            world.add_car(racer.model.build(world.space, pose, racer.car.car, draw.track))
        if len(racers) > 1:
            names = [racer.id for racer in racers]
            problems = placement_problems(
                draw.track,
                world.states(),
                names,
                start.source,
                start.paths,
                start.hint,
                start.value,
                footprints=world.footprints(),
            )
            if problems:
                raise ConfigError(problems)
        rules = self.track.rules
        self.rules: list[list[Rule]] = [[rule_type(name)(self.track) for name in p] for p in parts]
        self._reset_step = rules.reset_step
        self._labels = {
            "track": self.track_index,
            "spawn": self.spawn_index,
            "unit": self.track.unit,
        }
        self._info_labels = rules.info_labels
        self.laps = config.race.laps
        self.steps = 0  # steps since the reset (the reset's own not counted)
        self.lap_ends: list[list[int]] = [[] for _ in racers]  # per car: the step of each lap

    @property
    def visit_order(self) -> list[int]:
        """The first car's tiles in the order first visited (pictures repaint them)."""
        for rule in self.rules[0]:
            order: list[int] | None = getattr(rule, "visit_order", None)
            if order is not None:
                return order  # the rule's own list, read as it grows
        return []

    def progress(self, car: int) -> int:
        """Tiles car ``car`` has visited, every finished lap counting all of them (0 on a
        track without tiles)."""
        rules = self.rules[car]
        visited = max((getattr(rule, "visited_count", 0) for rule in rules), default=0)
        total = max((len(getattr(rule, "visited", ())) for rule in rules), default=0)
        laps = len(self.lap_ends[car])
        return laps * total + (visited if laps < self.laps else 0)

    def position(self, car: int) -> int:
        """Car ``car``'s place in the race: 1 + the cars further on (more tiles visited, or
        as many and the race finished earlier)."""
        return self.positions()[car]

    def positions(self) -> list[int]:
        """Every car's ``position``, each car's standing read once (a race's step asks for
        all of them)."""
        standings = [self._standing(car) for car in range(len(self.rules))]
        return [1 + sum(other > mine for other in standings) for mine in standings]

    def _standing(self, car: int) -> tuple[int, float]:
        ends = self.lap_ends[car]
        finished = len(ends) >= self.laps
        return self.progress(car), -float(ends[-1]) if finished else -math.inf

    def lap_times(self, car: int, dt: float) -> list[float]:
        """[s] of sim time of each lap car ``car`` finished (``dt``: the step [s])."""
        ends = self.lap_ends[car]
        return [(end - begin) * dt for begin, end in zip([0, *ends], ends, strict=False)]

    def lap_of(self, car: int) -> int:
        """The lap (0 first) of the tiles car ``car`` visited in the last step."""
        ends = self.lap_ends[car]
        done = len(ends) - (1 if ends and ends[-1] == self.steps else 0)
        return min(done, self.laps - 1)

    def start(self, dt: float) -> list[StepFacts]:
        """The reset's step: one physics step with no action (CarRacing), or a look at the
        spawn (the cars do not move); either way the rules judge it. Each car's facts."""
        if self._reset_step:
            facts = self.step(dt)
            self.steps = 0
            return facts
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
        self.steps += 1
        return self._judge()

    def leave(self, car: int, reason: str) -> None:
        """Car ``car``'s episode ended for ``reason``: a car that finished its race is taken
        off the track (it does not block the line), any other is parked as an obstacle."""
        if reason == "lap_finished":
            self.world.retire(car)
        else:
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
            if facts[car].lap_finished:
                self._lap(car, facts[car])
        return facts

    def _lap(self, car: int, facts: StepFacts) -> None:
        """Car ``car`` finished a lap: its time is kept; before its last lap the episode goes
        on with every tile to visit again."""
        ends = self.lap_ends[car]
        if len(ends) >= self.laps:
            return  # finished already (a car that is not parked, in a single-agent env)
        ends.append(self.steps)
        if len(ends) < self.laps:
            facts.lap_finished = False
            for rule in self.rules[car]:
                new_lap = getattr(rule, "new_lap", None)
                if new_lap is not None:
                    new_lap()

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
