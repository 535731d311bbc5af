"""One path for configuration: YAML files, dicts and ``gym.make`` kwargs become ``EnvConfig``."""

from __future__ import annotations

import dataclasses
import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

from tinyrace.cache import Settings, default_folder
from tinyrace.config.bounds import MAX_CAMERA_PIXELS, MAX_TEXTURE_SIDE, PERSPECTIVE_PIXEL_WEIGHT
from tinyrace.config.camera_info import intrinsics_problems, with_camera_info
from tinyrace.config.colors import Color
from tinyrace.config.loader import Parser, deep_merge, read_yaml
from tinyrace.config.race import (
    RaceCar,
    inherited,
    lay_cars_over_car,
    race_cars,
    race_problems,
    resolve_race_cars,
)
from tinyrace.config.schema import (
    F1TENTH_GYM_RATE,
    MAX_RACE_CARS,
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
from tinyrace.config.sensors import (
    ConesConfig,
    LidarConfig,
    PerspectiveCameraConfig,
    SensorConfig,
    cameras_first,
)
from tinyrace.errors import ConfigError, Problem, did_you_mean
from tinyrace.examples import find_track, track_names

__all__ = [
    "MAX_TEXTURE_SIDE",
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
    "race_cars",
]

TRACK_FILE = "track.yaml"


def car_colors(config: EnvConfig) -> list[Color]:
    """Each car's colour, in car order (what cameras, the overview and videos draw): its
    ``race.cars[i].colour``, else the palette's colour of its index."""
    return [car.colour for car in race_cars(config)]


def cache_settings(config: EnvConfig) -> Settings:
    """Where the config's envs keep shared track data on disk, and how much (``cache``)."""
    cache = config.cache
    folder = Path(cache.dir).expanduser() if cache.dir is not None else default_folder()
    return Settings(folder, int(cache.max_size * 2**20))


def car_names(config: EnvConfig) -> list[str]:
    """Each car's name, in car order: its agent name in a race (its ``race.cars[i].id``, else
    ``car_<i>``), the label the overview and videos write beside it."""
    return [car.id for car in race_cars(config)]


KWARGS = "<kwargs>"  # the source named by problems of ``gym.make``'s keyword arguments
DEFAULTS = "<defaults>"  # the source of a config made of defaults and overrides only


@dataclass(frozen=True)
class Overrides:
    """Keys laid over a config file (``gym.make``'s keyword arguments, an experiment's
    ``env:``), and what a problem in one of them names: their source and a key prefix."""

    keys: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    source: str = KWARGS
    prefix: str = ""  # e.g. "env." inside an experiment file


@dataclass(frozen=True)
class LoadedConfig:
    """A validated config, with where it came from (for errors) and where its images live."""

    config: EnvConfig
    source: str  # file path or "<dict>", used in error messages
    base_dir: Path  # images are relative to this
    overrides: Overrides = Overrides()  # what was laid over ``source``

    def blame(self, problems: list[Problem]) -> list[Problem]:
        """Each problem named where its value came from: a key given as an override names
        the overrides' source (a keyword argument, the experiment file), not the track file."""
        return blame(problems, self.source, self.overrides)


def blame(problems: list[Problem], source: str, overrides: Overrides) -> list[Problem]:
    """``problems`` found in ``source`` merged with ``overrides``, each renamed to the
    overrides' source when its key path lies in an override (or no file was read)."""
    renamed = []
    for p in problems:
        if p.source == source and (source == DEFAULTS or _overridden(p.path, overrides.keys)):
            p = Problem(overrides.source, f"{overrides.prefix}{p.path}", p.value, p.allowed)
        renamed.append(p)
    return renamed


_SINGULAR = {"tracks": "track", "cameras": "camera", "sensors": "sensor"}  # key aliases


def _spelled_as(overrides: Mapping[str, Any], raw: Mapping[str, Any]) -> dict[str, Any]:
    """``overrides`` with a section named as the file names it (``track=`` over a file's
    ``tracks:`` replaces it, rather than being the same key given twice)."""
    renamed = dict(overrides)
    for plural, singular in _SINGULAR.items():
        for given, written in ((plural, singular), (singular, plural)):
            if given in renamed and written in raw and written not in renamed:
                renamed[written] = renamed.pop(given)
    return renamed


def _overridden(path: str, keys: Mapping[str, Any]) -> bool:
    """Whether the value at ``path`` (``cameras[0].roi``) came from ``keys``: mappings merge
    key by key, anything else an override gives replaces the file's value whole."""
    tokens = re.findall(r"\[\d+\]|[^.\[\]]+", path)
    if not tokens:  # a top-level key of brackets and dots alone (``[``): itself or not
        return path in keys
    node: Any = keys
    for token in tokens:
        if not isinstance(node, Mapping):
            return True  # inside a list or value the override replaced
        if token.startswith("["):
            continue  # a mapping standing for a list of one (``track:``)
        token = token if token in node else _SINGULAR.get(token, token)  # tracks: track:
        if token not in node:
            return False
        node = node[token]
    return bool(path)


def load_env_config(
    config: str | Path | Mapping[str, Any] | LoadedConfig | None = None,
    environment: str | Path | None = None,
    overrides: Mapping[str, Any] | Overrides | None = None,
) -> LoadedConfig:
    """Read a track folder (``environment``), a YAML path or a dict, apply overrides, validate.

    With neither ``config`` nor ``environment``, the result is the default procedural track.
    Raises ConfigError listing every problem found, each named where it came from: the file
    and key path, or the keyword argument (plain ``overrides`` are ``gym.make``'s).
    """
    laid = overrides if isinstance(overrides, Overrides) else Overrides(overrides or {})
    if isinstance(config, LoadedConfig) and not laid.keys and environment is None:
        return config  # already validated (e.g. by ``tinyrace play``)
    if config is not None and environment is not None:
        raise ConfigError(
            Problem(
                KWARGS,
                "environment",
                str(environment),
                "give either config= or environment=, not both",
            )
        )
    raw, source, base_dir = _read_source(cast(_Source, config), environment)
    if laid.keys:
        raw = deep_merge(raw, _spelled_as(laid.keys, raw))
    if environment is not None and "tracks" not in raw and "track" not in raw:
        raw["tracks"] = [{}]  # a tinycarlo folder without tracks: its empty black plane
    try:
        parsed = with_camera_info(parse_env_config(raw, source), source, base_dir)
    except ConfigError as exc:
        raise ConfigError(blame(exc.problems, source, laid)) from None
    return LoadedConfig(parsed, source, base_dir, laid)


_Source = str | Path | Mapping[str, Any] | None  # what _read_source reads


def _read_source(
    config: str | Path | Mapping[str, Any] | None, environment: str | Path | None
) -> tuple[dict[str, Any], str, Path]:
    if environment is not None:
        if not isinstance(environment, (str, Path)):
            allowed = "expected a track folder (a path)"
            raise ConfigError(Problem("<kwargs>", "environment", environment, allowed))
        folder = find_track(environment)  # a path that exists wins over a shipped track's name
        config = folder / TRACK_FILE
        if not _safely(lambda: os.path.lexists(config)):  # a FIFO or a folder: read_yaml says
            raise ConfigError(Problem(KWARGS, "environment", str(environment), _no_track(folder)))
    if config is None:
        return {}, DEFAULTS, Path.cwd()
    if isinstance(config, Mapping):
        return dict(config), "<dict>", Path.cwd()
    if not isinstance(config, (str, Path)):
        raise ConfigError(Problem(KWARGS, "config", config, "expected a YAML path or a dict"))
    path = Path(config)
    if _safely(path.is_dir):
        path = path / TRACK_FILE
    raw = read_yaml(path)
    if raw is None:
        raw = {}
    if not isinstance(raw, Mapping):
        raise ConfigError(
            Problem(
                str(path), "", raw, "expected a YAML mapping of sections (sim, track, car, ...)"
            )
        )
    return dict(raw), str(path), path.parent


def _no_track(folder: Path) -> str:
    """What ``environment=`` expected, and what ``folder`` is instead."""
    expected = f"expected a track folder holding {TRACK_FILE}"
    if _safely(folder.is_file):
        return f"{expected}; this is a file: give a YAML config file as config= instead"
    if _safely(folder.is_dir):
        return f"{expected}; this folder holds no {TRACK_FILE}"
    names = track_names()
    return f"{did_you_mean(str(folder), names)}{expected} or a shipped track: {', '.join(names)}"


def _safely(check: Callable[[], bool]) -> bool:
    """A path check that is False, not an OSError, for names the OS refuses (too long, ...)."""
    try:
        return check()
    except (OSError, ValueError):
        return False


def parse_env_config(raw: Mapping[str, Any], source: str, prefix: str = "") -> EnvConfig:
    """Validate a raw mapping into an EnvConfig with every kind-dependent default resolved.

    ``prefix`` is put before key paths in messages (e.g. "env" inside an experiment file).
    """
    parser = Parser(source)
    raw, given = lay_cars_over_car(raw)  # each race car's knobs over the car section
    config = parser.dataclass(EnvConfig, raw, prefix)
    at = f"{prefix}." if prefix else ""
    parser.problems = inherited(parser.problems, given, at)  # reported at car.<key> once
    if parser.parsed(config):  # also when some keys were bad: report every problem at once
        _check_consistency(config, parser, at)
    parser.check()
    return resolve_race_cars(resolve_defaults(config))


def _check_consistency(config: EnvConfig, parser: Parser, at: str) -> None:
    """Rules that span sections; ``at`` prefixes key paths."""
    kinds = {t.type for t in config.tracks}
    if len(kinds) > 1:
        parser.problem(f"{at}tracks", sorted(kinds), "all tracks of one env must be of one type")
    if not config.tracks:
        parser.problem(f"{at}tracks", [], "expected at least one track")
    facts = config.facts if config.tracks else None
    seen = facts is None or facts.default_view  # a view without cameras (96x96)
    if not seen and not config.cameras and not config.sensors:
        allowed = (
            f"an {config.kind} track needs at least one camera (id, resolution, roi, position)"
        )
        parser.problem(f"{at}cameras", [], allowed)
    _check_observation(config, parser, at, f"{at}observation")
    # the car model and its actions are checked by tinyrace.cars.registry
    picture = facts is not None and facts.colour_picture
    if not picture and config.reward_design.color_obstacles:
        obstacles = [repr(o.color) for o in config.reward_design.color_obstacles]
        allowed = "colour obstacles need an image track"
        parser.problem(f"{at}reward_design.color_obstacles", obstacles, allowed)
    _check_obstacle_colors(config.reward_design, parser, at)
    for i, track in enumerate(config.tracks):
        for key, value, allowed in track.problems(config.files):
            parser.problem(f"{at}tracks[{i}].{key}", value, allowed)
    _check_race(config, parser, at, not seen)


def _check_observation(config: EnvConfig, parser: Parser, at: str, observation_at: str) -> None:
    """One car's cameras and sensors: unique ids, ``observation: box``, pixels, intrinsics."""
    _check_box(config, parser, observation_at)
    ids = [c.id for c in config.cameras] + [sensor.id for sensor in config.sensors]
    cameras = len(config.cameras)
    for i, cam_id in enumerate(ids):
        if cam_id in ids[:i]:
            where = f"cameras[{i}].id" if i < cameras else f"sensors[{i - cameras}].id"
            parser.problem(f"{at}{where}", cam_id, "camera and sensor ids must be unique")
    _check_camera_pixels(config, parser, at)
    for i, sensor in enumerate(config.sensors):
        if isinstance(sensor, PerspectiveCameraConfig):
            for key, value, allowed in intrinsics_problems(sensor):
                parser.problem(f"{at}sensors[{i}].{key}", value, allowed)
            position = sensor.position
            if position and not position[2] > 0:
                allowed = "expected a camera above the ground: position [x, y, z] with z > 0"
                parser.problem(f"{at}sensors[{i}].position", list(position), allowed)


def _check_race(config: EnvConfig, parser: Parser, at: str, needs_camera: bool) -> None:
    """The race as a whole (count, ids, poses), and each car's own cameras and sensors."""
    cars = config.race.cars
    if len(cars) > MAX_RACE_CARS:
        allowed = f"expected at most {MAX_RACE_CARS} cars (one world holds {MAX_RACE_CARS})"
        parser.problem(f"{at}race.cars", f"{len(cars)} cars", allowed)
        return
    parser.problems += race_problems(config, at, parser.source)
    for i, entry in enumerate(cars):
        if entry.cameras is None and entry.sensors is None:
            continue  # the shared ones, checked above
        car = race_cars(config)[i]
        own = dataclasses.replace(config, cameras=car.cameras, sensors=car.written_sensors)
        car_at = f"{at}race.cars[{i}]."
        if needs_camera and not own.cameras and not own.sensors:
            allowed = f"car {car.id!r} on an {config.kind} track needs at least one camera"
            parser.problem(f"{car_at}cameras", [], allowed)
        _check_observation(own, parser, car_at, f"{car_at}sensors")


def _one_array(sensor: SensorConfig) -> bool:
    """Whether a sensor's observation is one array (a Box), not a Dict of arrays."""
    if isinstance(sensor, LidarConfig):
        return not sensor.hit_classes
    return not isinstance(sensor, ConesConfig)


def _check_box(config: EnvConfig, parser: Parser, where: str) -> None:
    """``observation: box`` is one camera's image: exactly one camera or image sensor (a
    problem names ``where``)."""
    if config.observation != "box":
        return
    ids = [c.id for c in config.cameras] + [s.id for s in config.sensors]
    allowed = ""
    if len(ids) > 1:
        allowed = f"box needs exactly one camera or sensor, not {ids} (use dict)"
    elif config.sensors and not _one_array(config.sensors[0]):
        allowed = (
            f"box needs a camera or a sensor of one array, not a {config.sensors[0].type} "
            "sensor whose observation is a Dict (cones; lidar with hit_classes): use dict"
        )
    if allowed:
        parser.problem(where, "box", allowed)


def _check_obstacle_colors(reward: RewardConfig, parser: Parser, at: str) -> None:
    """An obstacle in the trajectory's colour could never be hit: its pixels are taken out."""
    cte = reward.cross_track_error
    for i, obstacle in enumerate(reward.color_obstacles):
        if cte.use_cte and obstacle.color == cte.trajectory_color:
            allowed = (
                "expected a colour other than cross_track_error.trajectory_color (trajectory "
                "pixels are taken out of the picture, so this obstacle could never be hit)"
            )
            parser.problem(f"{at}reward_design.color_obstacles[{i}].color", obstacle.color, allowed)


def _check_camera_pixels(config: EnvConfig, parser: Parser, at: str) -> None:
    """Every camera's pixels together: the ``cameras`` and the perspective ``sensors`` (whose
    pixels count PERSPECTIVE_PIXEL_WEIGHT times: each keeps a ray and its ground point)."""
    sizes = [(f"cameras[{i}]", c.resolution, 1) for i, c in enumerate(config.cameras)]
    sizes += [
        (f"sensors[{i}]", s.resolution, PERSPECTIVE_PIXEL_WEIGHT)
        for i, s in enumerate(config.sensors)
        if isinstance(s, PerspectiveCameraConfig)
    ]
    total = sum(height * width * weight for _, (height, width), weight in sizes)  # [px]
    if total > MAX_CAMERA_PIXELS:
        allowed = (
            f"expected cameras of at most {MAX_CAMERA_PIXELS:,} px together, a perspective_camera "
            f"pixel counted {PERSPECTIVE_PIXEL_WEIGHT} times (here {total:,})"
        )
        where = "cameras" if not config.sensors else "sensors"
        parser.problem(f"{at}{where}", {k: list(r) for k, r, _ in sizes}, allowed)


def resolve_defaults(config: EnvConfig) -> EnvConfig:
    """Fill the ``None`` knobs whose default depends on the track (its config's facts); the
    ``cameras`` join the ``sensors``."""
    facts = config.facts
    carracing_rules = facts.carracing_rules  # tiles, laps, time penalty
    sim = config.sim
    if sim.fps is None:
        fps = 50.0 if carracing_rules else 30.0
        sim = dataclasses.replace(sim, fps=F1TENTH_GYM_RATE if config.car.compat else fps)
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
