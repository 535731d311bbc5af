"""Defaults that depend on the track (its config's facts), filled after parsing; and where
the config's envs keep shared track data."""

from __future__ import annotations

import dataclasses

from tinyrace.cache import Settings, default_folder, folder_of
from tinyrace.config.schema import F1TENTH_GYM_RATE, EnvConfig
from tinyrace.config.sensors import SensorConfig, cameras_first


def cache_settings(config: EnvConfig) -> Settings:
    """Where the config's envs keep shared track data on disk, and how much (``cache``)."""
    cache = config.cache
    folder = (
        default_folder() if cache.dir is None else folder_of(cache.dir, "<config>", "cache.dir")
    )
    return Settings(folder, int(cache.max_size * 2**20))


def resolve_defaults(config: EnvConfig) -> EnvConfig:
    """Fill the ``None`` knobs whose default depends on the track (its config's facts); the
    ``cameras`` join the ``sensors``."""
    facts = config.facts
    carracing_rules = facts.carracing_rules  # tiles, laps, time penalty
    sim = config.sim
    if sim.fps is None:
        fps = 50.0 if carracing_rules else 30.0
        compat = config.car.compat or any(e.car.compat for e in config.race.cars)  # any car
        sim = dataclasses.replace(sim, fps=F1TENTH_GYM_RATE if compat else fps)
    sizes = facts.car_sizes
    car = config.car
    car = dataclasses.replace(
        car,
        wheelbase=_default(car.wheelbase, sizes["wheelbase"]),
        track_width=_default(car.track_width, sizes["track_width"]),
        velocity=_default(car.velocity, sizes["velocity"]),
        pixels_per_unit=_default(car.pixels_per_unit, sizes["pixels_per_unit"]),
    )
    reward = config.reward_design
    reward = dataclasses.replace(
        reward,
        tile_progress=_default(reward.tile_progress, 1000.0 if carracing_rules else 0.0),
        time_penalty=_default(reward.time_penalty, 0.1 if carracing_rules else 0.0),
        out_of_bounds_penalty=_default(
            reward.out_of_bounds_penalty, 100.0 if carracing_rules else 0.0
        ),
    )
    sensors = _with_cameras(config)
    return dataclasses.replace(config, sim=sim, car=car, reward_design=reward, sensors=sensors)


def _with_cameras(config: EnvConfig) -> tuple[SensorConfig, ...]:
    """tinycarlo's ``cameras:`` as ``birdseye_camera`` sensors, first in the ``sensors`` list
    (in their order; once: a config already resolved keeps its list). ``cameras`` stays as
    written, for messages that name its keys; each race car's are put first in its sensors
    by ``race_cars``."""
    return cameras_first(config.cameras, config.sensors)


def _default(value: float | None, default: float) -> float:
    return default if value is None else value
