"""One episode: a world with the track's static shapes and the cars, judged by rule parts.

The track says which rule parts its episodes are made of (``Track.rules``; the config's
``rules:`` entries add more); the ``Course`` (``course.py``, made once per env) furnishes
one world per track with what those parts need and hands it to each new ``Episode``. The
episode owns the step for all its cars, once: it builds the parts for each car, moves the
world, turns its contacts into each car's ``StepFacts``, and keeps the clock, the step
counter, each car's score and carried reward; its ``Referee`` turns the facts into each
car's ``CarStep`` (reward terms, reward, end, truncation). The envs call it and adapt the
result. Nothing here depends on the kind of track.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from tinyrace.cars.registry import CarModel
from tinyrace.config import EnvConfig, RaceCar
from tinyrace.episodes.referee import CarStep, Referee
from tinyrace.episodes.rules import RULES, Rule
from tinyrace.episodes.start_pose import placement_problems
from tinyrace.errors import ConfigError
from tinyrace.rewards import Judging
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
        settings = {entry.type: entry for entry in config.rules}  # parts' own knobs
        always = tuple(name for name, part in RULES.items() if part.always)
        self.parts = [(*always, *names) for names in parts]  # each car's, by name
        self.rules: list[list[Rule]] = [
            [make(self.track, settings.get(name)) for name in p if (make := RULES[name].make)]
            for p in self.parts
        ]
        self._reset_step = rules.reset_step
        self._labels = {
            "track": self.track_index,
            "spawn": self.spawn_index,
            "unit": self.track.unit,
        }
        self._info_labels = rules.info_labels
        self.laps = config.race.laps
        self.steps = 0  # steps since the reset (the reset's own not counted): the one counter
        self.t = 0.0  # [s] of sim time since the reset (its own step counted)
        self.lap_ends: list[list[int]] = [[] for _ in racers]  # per car: the step of each lap
        self.scores = [0.0 for _ in racers]  # each car's running reward (CarRacing's score)
        self.carry: list[dict[str, float]] = [{} for _ in racers]  # the reset's, paid next
        self.facts: list[StepFacts] = []  # every car's facts of the last step
        self._judging: list[Judging] = []
        self.referee: Referee | None = None  # set by ``start``
        tiles = 0 if self.track.tiles is None else len(self.track.tiles)
        first = config.race.tile_reward == "first" and len(racers) > 1
        # ``race.tile_reward: first``: per lap, the tiles paid already
        self._claimed = np.zeros((self.laps, tiles), bool) if first else None

    @property
    def visit_order(self) -> list[int]:
        """The first car's tiles in the order first visited (pictures repaint them)."""
        for rule in self.rules[0]:
            progress = rule.tile_progress()
            if progress is not None:
                return progress.visit_order  # the rule's own list, read as it grows
        return []

    def progress(self, car: int) -> int:
        """Tiles car ``car`` has visited, every finished lap counting all of them (0 on a
        track without tiles)."""
        counts = [p for rule in self.rules[car] if (p := rule.tile_progress()) is not None]
        visited = max((p.visited_count for p in counts), default=0)
        total = max((len(p.visited) for p in counts), default=0)
        laps = len(self.lap_ends[car])
        return laps * total + (visited if laps < self.laps else 0)

    def position(self, car: int) -> int:
        """Car ``car``'s place in the race: 1 + the cars further on (more tiles visited, or
        as many and the race finished earlier); cars level share a place (all 1 at reset:
        the race hashes record it so)."""
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

    def start(self, referee: Referee) -> list[StepFacts]:
        """The reset's step, judged by ``referee`` (and every step after it): one physics
        step with no action (CarRacing), or a look at the spawn (the cars do not move);
        either way the rules judge it. It is not rewarded: each car carries the terms its
        first step pays (CarRacing's tiles), which its score starts with. Each car's facts."""
        self.referee = referee
        dt = referee.dt
        if self._reset_step:
            self.world.apply_forces(dt)
            self.world.advance(dt)
            self.steps += 1
            facts = self._judge()
            self.steps = 0
        else:
            self.world.look(dt)
            facts = self._judge()
        self.t += dt
        self._judging = [referee.parts(names) for names in self.parts]
        self.carry = [referee.carried(f, j) for f, j in zip(facts, self._judging, strict=True)]
        self.scores = [0.0 + sum(carry.values()) for carry in self.carry]
        self.facts = facts
        return facts

    def step(self) -> list[CarStep | None]:
        """One step of every car with the controls it holds: the world moved, the rules'
        facts, each car judged (None for a car out of the race)."""
        referee = self.referee
        if referee is None:
            raise RuntimeError("an episode steps once started (start(referee))")
        self.world.apply_forces(referee.dt)
        return self._moved(referee)

    def advance(self) -> list[CarStep | None]:
        """The rest of a step whose forces are set (a batch set them): as ``step``."""
        referee = self.referee
        if referee is None:
            raise RuntimeError("an episode steps once started (start(referee))")
        return self._moved(referee)

    def _moved(self, referee: Referee) -> list[CarStep | None]:
        """The world advanced by the clock's step, every car's facts (a parked car's rules
        judge no more: its facts stay empty), the clock on, each car judged."""
        self.world.advance(referee.dt)
        self.steps += 1
        self.t += referee.dt
        self.facts = facts = self._judge()
        if self._claimed is not None:
            self._pay_first_visits(facts)
        parked, steps = self.world.parked, self.steps
        results: list[CarStep | None] = []
        for car, fact in enumerate(facts):
            if car in parked:
                results.append(None)
                continue
            carried = self.carry[car]
            if carried:
                self.carry[car] = {}
            result, scored = referee.judge(fact, self._judging[car], carried, steps)
            if scored:
                self.scores[car] += result.reward - sum(carried.values())
            results.append(result)
        return results

    def _pay_first_visits(self, facts: list[StepFacts]) -> None:
        """``race.tile_reward: first``: a tile first visited in a lap by several cars pays
        the first only."""
        claimed_per_lap = self._claimed
        assert claimed_per_lap is not None
        for car, fact in enumerate(facts):
            claimed = claimed_per_lap[self.lap_of(car)]
            paid = [tile for tile in fact.tiles if not claimed[tile]]
            claimed[paid] = True
            fact.new_tiles = len(paid)

    def judging(self, car: int = 0) -> Judging:
        """The reward terms and ends car ``car``'s steps are judged by (once started)."""
        return self._judging[car]

    def snapshot(self) -> Snapshot:
        """A copy of the world's state now, labelled with the clock and car 0's score."""
        return self.world.snapshot(self.t, self.steps, self.scores[0])

    def leave(self, car: int, reason: str) -> None:
        """Car ``car``'s episode ended for ``reason``: a car that finished its race is taken
        off the track (it does not block the line), any other is parked as an obstacle."""
        if reason == "lap_finished":
            self.world.retire(car)
        else:
            self.world.park(car)

    def _judge(self) -> list[StepFacts]:
        world, referee = self.world, self.referee
        assert referee is not None  # judging starts with start(referee)
        states, contacts, parked = world.states(), world.contacts, world.parked
        facts = [StepFacts(referee.dt) for _ in world.cars]
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
                rule.new_lap()

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
