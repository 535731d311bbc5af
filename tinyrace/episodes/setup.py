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
from tinyrace.episodes.image import ImageCourse
from tinyrace.episodes.metric import MetricCourse
from tinyrace.episodes.procedural import ProceduralCourse
from tinyrace.errors import ConfigError, Problem
from tinyrace.tracks.base import TrackSource
from tinyrace.tracks.image import ImageSource
from tinyrace.tracks.metric import MetricSource
from tinyrace.tracks.procedural_source import ProceduralSource
from tinyrace.tracks.registry import make_track_source

Course = ProceduralCourse | ImageCourse | MetricCourse


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
    car = dataclasses.replace(loaded.config.car, model=car_model.name)  # type: ignore[arg-type]
    config = dataclasses.replace(loaded.config, car=car)
    return Parts(config, car_model, source, _course(config, source, car_model))


def _course(config: EnvConfig, source: TrackSource, car_model: CarModel) -> Course:
    if isinstance(source, ProceduralSource):
        return ProceduralCourse(config, source, car_model)
    if isinstance(source, MetricSource):
        return MetricCourse(config, source, car_model)
    assert isinstance(source, ImageSource)
    return ImageCourse(config, source, car_model)
