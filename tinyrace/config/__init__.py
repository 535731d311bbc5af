"""One path for configuration: YAML files, dicts and ``gym.make`` kwargs become ``EnvConfig``.

What lives where: ``schema.py``, ``sensors.py``, ``tracks.py`` and ``race.py`` hold the
sections as dataclasses (``families.py``: the open lists told apart by ``type``);
``loader.py`` parses a mapping into them; ``load.py`` reads a source (a track folder, a
YAML path, a dict) into a ``LoadedConfig``; ``overrides.py`` lays keyword arguments over it
and names each problem where its value came from; ``checks.py`` holds the rules that span
sections; ``defaults.py`` fills the knobs whose default depends on the track. This module
only re-exports.
"""

from __future__ import annotations

from tinyrace.config.bounds import MAX_TEXTURE_SIDE
from tinyrace.config.colors import Color
from tinyrace.config.defaults import cache_settings, resolve_defaults
from tinyrace.config.load import TRACK_FILE, LoadedConfig, load_env_config, parse_env_config
from tinyrace.config.overrides import Overrides
from tinyrace.config.race import RaceCar, car_colors, car_names, race_cars
from tinyrace.config.schema import (
    CacheConfig,
    CameraConfig,
    CarConfig,
    CenterlineTrackConfig,
    ColorObstacle,
    ConeMapTrackConfig,
    CrossTrackErrorConfig,
    EnvConfig,
    ImageTrackConfig,
    ProceduralTrackConfig,
    RewardConfig,
    RosMapTrackConfig,
    SimConfig,
    TrackConfig,
)
from tinyrace.errors import ConfigError

__all__ = [
    "MAX_TEXTURE_SIDE",
    "TRACK_FILE",
    "CacheConfig",
    "CameraConfig",
    "CarConfig",
    "CenterlineTrackConfig",
    "Color",
    "ColorObstacle",
    "ConeMapTrackConfig",
    "ConfigError",
    "CrossTrackErrorConfig",
    "EnvConfig",
    "ImageTrackConfig",
    "LoadedConfig",
    "Overrides",
    "ProceduralTrackConfig",
    "RaceCar",
    "RewardConfig",
    "RosMapTrackConfig",
    "SimConfig",
    "TrackConfig",
    "cache_settings",
    "car_colors",
    "car_names",
    "load_env_config",
    "parse_env_config",
    "race_cars",
    "resolve_defaults",
]
