"""From a loaded config to the parts of an env: car models, track source, course.

``prepare`` is the one path from a config to something that can reset: ``gym.make`` (the
env's constructor) and ``tinyrace validate`` both call it, so whatever validate accepts
builds, and every problem it finds is reported the same way.

The cars of a race may be of different models in one world: each car model drives its own
body and meets the others through the world's outlines (a crash stops both, whatever the
models), so a model is refused only where it cannot drive (its track kinds, its actions).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from tinyrace.cars.registry import CarModel, car_model_problems, choose_car_model
from tinyrace.config import EnvConfig, LoadedConfig, RaceCar, race_cars
from tinyrace.episodes.course import Course
from tinyrace.episodes.episode import Racer
from tinyrace.episodes.rules import rule_problems
from tinyrace.episodes.start_pose import start_fits, start_problems
from tinyrace.errors import ConfigError, Problem
from tinyrace.tracks.base import TrackSource
from tinyrace.tracks.registry import make_track_source


@dataclass(frozen=True, eq=False)
class Parts:
    """What an env is made of, before any reset."""

    config: EnvConfig  # car 0's car (``car.model`` resolved), cameras and sensors on top
    car_model: CarModel  # car 0's
    source: TrackSource
    course: Course
    racers: tuple[Racer, ...]  # every car of the race, car 0 first


def prepare(loaded: LoadedConfig) -> Parts:
    """Choose the cars, load the tracks, prepare the course; ConfigError lists every problem."""
    cars = race_cars(loaded.config)
    problems: list[Problem] = car_model_problems(loaded.config, loaded.source)
    problems += rule_problems(loaded.config, loaded.source)
    for car in cars:
        if car.own_car:
            problems += _own_car_problems(loaded.config, car, loaded.source, problems)
    try:
        source = make_track_source(loaded.config, loaded.base_dir, loaded.source)
    except ConfigError as exc:
        problems += exc.problems
    if problems:  # each named where its value came from (the file or a keyword argument)
        raise ConfigError(loaded.blame(problems))
    racers = tuple(_racer(loaded.config, car) for car in cars)
    config = _with_cars(loaded.config, racers)
    car_model = racers[0].model
    tracks = getattr(source, "tracks", ())  # a source's fixed tracks (none: drawn per reset)
    fits = start_fits(config, tracks, car_model)  # the car must fit at every spawn
    if any(not fit.free for fit in fits):
        raise ConfigError(loaded.blame(start_problems(config, fits, loaded.source)))
    course = Course(config, racers, loaded.source)
    grid_problems = course.check_fixed_starts(tracks)  # every car of the grid fits too
    if grid_problems:
        raise ConfigError(loaded.blame(grid_problems))
    return Parts(config, car_model, source, course, racers)


def _own_car_problems(
    config: EnvConfig, car: RaceCar, source: str, shared: list[Problem]
) -> list[Problem]:
    """The problems of a ``race.cars`` entry's car, named at the entry (those it inherited
    from the car section are named there once)."""
    own = car_model_problems(dataclasses.replace(config, car=car.car), source)
    seen = {(p.path, repr(p.value), p.allowed) for p in shared}
    at = f"race.cars[{car.index}]."
    return [_at_entry(p, at) for p in own if (p.path, repr(p.value), p.allowed) not in seen]


def _at_entry(problem: Problem, at: str) -> Problem:
    """``problem`` of a race entry's car, named at the entry; a shared section's key (``sim``:
    one clock for every car) stays named where it is, the entry named in the text."""
    if problem.path.startswith("sim."):
        return dataclasses.replace(problem, allowed=f"{problem.allowed} (for {at}car)")
    return dataclasses.replace(problem, path=f"{at}{problem.path}")


def _racer(config: EnvConfig, car: RaceCar) -> Racer:
    """``car`` with its model chosen and named in its car config."""
    model = choose_car_model(dataclasses.replace(config, car=car.car), "<config>")
    named = dataclasses.replace(car.car, model=model.name)
    return Racer(dataclasses.replace(car, car=named), model)


def _with_cars(config: EnvConfig, racers: tuple[Racer, ...]) -> EnvConfig:
    """``config`` with car 0's car, cameras and sensors on top (what a single-agent env
    drives and sees) and every ``race.cars`` entry resolved (its id, car, colour, cameras,
    sensors), so that ``race_cars`` of the result reads the same cars."""
    first = racers[0].car
    race = config.race
    if race.cars:
        entries = tuple(
            dataclasses.replace(
                entry,
                id=racer.car.id,
                car=racer.car.car,
                colour=racer.car.colour,
                cameras=racer.car.cameras,
                sensors=racer.car.sensors,
            )
            for entry, racer in zip(race.cars, racers, strict=True)
        )
        race = dataclasses.replace(race, cars=entries)
    return dataclasses.replace(
        config, car=first.car, cameras=first.cameras, sensors=first.sensors, race=race
    )
