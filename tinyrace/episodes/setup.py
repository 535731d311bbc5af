"""From a loaded config to the parts of an env: car model, track source, course.

``prepare`` is the one path from a config to something that can reset: ``gym.make`` (the
env's constructor) and ``tinyrace validate`` both call it, so whatever validate accepts
builds, and every problem it finds is reported the same way.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from tinyrace.cars.registry import CarModel, car_model_problems, choose_car_model
from tinyrace.config import EnvConfig, LoadedConfig
from tinyrace.episodes.episode import Course
from tinyrace.episodes.start_pose import start_fits, start_problems
from tinyrace.errors import ConfigError, Problem
from tinyrace.tracks.base import TrackSource
from tinyrace.tracks.registry import make_track_source


@dataclass(frozen=True, eq=False)
class Parts:
    """What an env is made of, before any reset."""

    config: EnvConfig  # with ``car.model`` resolved to the chosen model's name
    car_model: CarModel
    source: TrackSource
    course: Course


def prepare(loaded: LoadedConfig) -> Parts:
    """Choose the car, load the tracks, prepare the course; ConfigError lists every problem."""
    problems: list[Problem] = car_model_problems(loaded.config, loaded.source)
    try:
        source = make_track_source(loaded.config, loaded.base_dir, loaded.source)
    except ConfigError as exc:
        problems += exc.problems
    if problems:  # each named where its value came from (the file or a keyword argument)
        raise ConfigError(loaded.blame(problems))
    car_model = choose_car_model(loaded.config, loaded.source)
    car = dataclasses.replace(loaded.config.car, model=car_model.name)
    config = dataclasses.replace(loaded.config, car=car)
    tracks = getattr(source, "tracks", ())  # a source's fixed tracks (none: drawn per reset)
    fits = start_fits(config, tracks, car_model)  # the car must fit at every spawn
    if any(not fit.free for fit in fits):
        raise ConfigError(start_problems(config, fits, loaded.source))
    return Parts(config, car_model, source, Course(config, car_model))
