"""What ``tinyrace validate`` and ``show`` read: a track folder, a track.yaml or an experiment."""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from tinyrace.config import TRACK_FILE, EnvConfig, LoadedConfig, load_env_config, race_cars
from tinyrace.config.loader import read_yaml
from tinyrace.episodes.setup import Parts, prepare
from tinyrace.episodes.start_pose import start_fits
from tinyrace.errors import ConfigError, Problem
from tinyrace.sensors.base import Sensor

if TYPE_CHECKING:
    from tinyrace.env import TinyRaceEnv

COMMAND_LINE = "<command line>"  # the source named by errors in command-line arguments


def load_any(path: Path) -> LoadedConfig:
    """The env config behind a track folder, a track.yaml or an experiment file."""
    from tinyrace.experiment import is_experiment, load_experiment
    from tinyrace.experiment.target import not_runnable

    if path.is_dir():
        if not (path / TRACK_FILE).is_file():  # say what the folder is instead
            raise ConfigError(Problem(COMMAND_LINE, "path", str(path), not_runnable(path)))
        return load_env_config(environment=path)
    raw = read_yaml(path)
    if is_experiment(raw):
        return load_experiment(path).loaded  # named in the experiment or its track file
    return load_env_config(config=path)


def build_course(loaded: LoadedConfig) -> Parts:
    """Load everything the env would load at construction (images included), as it does."""
    return prepare(loaded)


def validate_path(path: Path) -> tuple[list[str], str]:
    """Every problem found (as lines), or none and a one-line summary.

    What passes has been built, reset (seed 0) and stepped once, as ``gym.make`` and
    ``tinyrace run`` would: they read the config through the same functions.
    """
    problems, summary = validate_problems(path)
    return [str(p) for p in problems], summary


def validate_problems(path: Path) -> tuple[list[Problem], str]:
    """``validate_path``'s answer as problems (a long list ends with an ``Omitted``, which
    says how many more were found)."""
    try:
        loaded = load_any(path)
        parts = build_course(loaded)  # the same parts the env is made of
        observes = try_one_step(loaded)
    except ConfigError as exc:
        return exc.problems, ""
    return [], describe(parts.config, observes) + start_summary(parts)


def start_summary(parts: Parts) -> str:
    """'; start free: ...' on tracks with walls, cones or obstacle colours: the car's
    footprint at its spawns and how far it is from the nearest wall and cone (``prepare``
    refuses a spawn that overlaps either or covers an obstacle colour's pixel)."""
    fits = start_fits(parts.config, parts.source.tracks, parts.car_model)
    if not fits:
        return ""
    length, width = fits[0].size
    unit = fits[0].unit
    text = f"; start free: car footprint {length:.2f} x {width:.2f} {unit}"
    for name, clearance in (
        ("wall", min(f.wall_clearance for f in fits)),
        ("cone", min(f.cone_clearance for f in fits)),
    ):
        if math.isfinite(clearance):
            text += f", {clearance:.2f} {unit} from the nearest {name}"
    return text


def try_one_step(loaded: LoadedConfig) -> str:
    """Build the env of ``loaded``, reset it with seed 0 and take one neutral step; how its
    steps are judged (``judging_summary``) and what its cars observe
    (``observation_summary``)."""
    from tinyrace.env import TinyRaceEnv

    env = TinyRaceEnv(config=loaded)
    try:
        env.reset(seed=0)
        env.step(neutral_action(env.action_space))
        return f"{judging_summary(env)}; {observation_summary(env)}"
    finally:
        env.close()


def judging_summary(env: TinyRaceEnv) -> str:
    """The reward terms that can pay and the ends of the first car's steps, in the order
    they are summed and asked (``rewards: time, tiles; ends: out_of_bounds, ...``)."""
    assert env.episode is not None  # reset
    judging = env.episode.judging(0)
    terms = [term.name for term in (*judging.alone, *judging.terms)]
    ends = [end.reason for end in judging.ends]
    return f"rewards: {', '.join(terms) or 'none'}; ends: {', '.join(ends) or 'none'}"


def neutral_action(space: gym.Space[Any]) -> Any:
    """The action nearest to 'do nothing': 0 clipped into a Box, the first of a Discrete."""
    if isinstance(space, gym.spaces.Discrete):
        return space.start
    if isinstance(space, gym.spaces.Box):
        return np.clip(np.zeros(space.shape), space.low, space.high).astype(space.dtype)
    return space.sample()  # another kind of space: any valid action


def describe(config: EnvConfig, observes: str) -> str:
    """One line: the tracks, the car model, the race (when there are several cars) and what
    the cars observe (``observation_summary``)."""
    text = (
        f"{config.kind} track ({len(config.tracks)} track(s)), {config.car.model} car, "
        f"{config.sim.fps:g} fps"
    )
    cars = race_cars(config)
    if len(cars) > 1:
        names = ", ".join(car.id for car in cars)
        laps = config.race.laps
        text += f"; race: {len(cars)} cars ({names}), {laps} lap{'s' if laps > 1 else ''}"
    return f"{text}; {observes}"


def observation_summary(env: TinyRaceEnv) -> str:
    """What the first car observes (``observes: ...``), then each race car with sensors of
    its own (`` | car_1 observes: ...``); the others observe as the first does."""
    sections = ["observes: " + "; ".join(observation_lines(env.sensors))]
    entries = env.config.race.cars
    for index, car in enumerate(race_cars(env.config)[1:], start=1):
        entry = entries[index] if index < len(entries) else None
        if entry is not None and (entry.cameras is not None or entry.sensors is not None):
            lines = observation_lines(env.make_sensors(index))
            sections.append(f"{car.id} observes: " + "; ".join(lines))
    return " | ".join(sections)


def observation_lines(sensors: Sequence[Sensor]) -> list[str]:
    """Each sensor the env observes: its id, its space's shapes and dtypes, and what it
    says it observes (``Sensor.describe``)."""
    return [f"{s.id} {space_text(s.space)} ({s.describe()})" for s in sensors]


def space_text(space: gym.Space[Any]) -> str:
    """A space's shape and dtype (``96x96x3 uint8``); a Dict's, key by key; a Discrete's
    values (``0..32``)."""
    if isinstance(space, gym.spaces.Dict):
        return "{" + ", ".join(f"{k}: {space_text(v)}" for k, v in space.spaces.items()) + "}"
    if isinstance(space, gym.spaces.Discrete):
        return f"{space.start}..{space.start + space.n - 1}"
    shape = "x".join(str(side) for side in space.shape or ())
    return f"{shape} {space.dtype}"


@dataclass(frozen=True)
class Picture:
    """A track's picture, the name to save it under, and the files it was made from."""

    image: np.ndarray  # (H, W, 3) uint8 RGB
    name: str
    inputs: tuple[Path, ...]  # resolved paths of every file read: never to be written over
    seeded: bool = False  # whether the seed chose it (a procedural track: one per seed)


def picture(target: str, seed: int) -> Picture:
    """The picture of a track; ``target`` 'procedural' means CarRacing's track."""
    from tinyrace.ground.grounds import make_ground
    from tinyrace.ground.metric import paint_ground
    from tinyrace.render.track_picture import (
        MAX_SIDE,
        framed_bounds,
        image_picture,
        metric_picture,
        procedural_picture,
    )

    if target == "procedural":  # the CLI's name for CarRacing's track
        image = procedural_picture(load_env_config().config, seed)
        return Picture(image, f"procedural-seed{seed}", (), seeded=True)
    path = Path(target)
    loaded = load_any(path)
    named = (path if path.is_dir() or path.name != TRACK_FILE else path.parent).resolve()
    name = named.name if named.is_dir() else named.stem  # `show .` names the folder
    inputs = input_files(path, loaded)
    parts = build_course(loaded)
    ground = make_ground(parts.config, parts.source)  # what the env's pictures are drawn on
    if ground.rescalable() is not None:  # a new track per seed, painted from its tiles
        image = procedural_picture(loaded.config, seed)
        return Picture(image, f"{name}-seed{seed}", inputs, seeded=True)
    first = parts.source.draw(np.random.default_rng(seed), {"track": 0, "spawn": 0}).track
    if ground.carries_pictures:
        return Picture(image_picture(parts.config, first), name, inputs)
    # framed on the road, cones and walls, not the whole playfield, and painted for the
    # picture alone at its own scale (the env's ground is the playfield's, unchanged)
    framed = dataclasses.replace(first, bounds=framed_bounds(first))
    x0, y0, x1, y1 = framed.bounds
    texture = paint_ground(framed, MAX_SIDE / max(x1 - x0, y1 - y0))
    return Picture(metric_picture(framed, texture, first.bounds), name, inputs)


def input_files(path: Path, loaded: LoadedConfig) -> tuple[Path, ...]:
    """Every file a config was read from: the YAML files and the track images."""
    files = [path / TRACK_FILE if path.is_dir() else path]
    if not loaded.source.startswith("<"):
        files.append(Path(loaded.source))
    for track in loaded.config.tracks:
        for key in ("image", "file", "waypoints"):  # picture and metric track files
            name = getattr(track, key, None)
            if isinstance(name, str):
                files.append(loaded.base_dir / name)
        file = getattr(track, "file", None)
        if track.occupancy_map and isinstance(file, str):  # the map YAML names its picture
            files += _map_image(loaded.base_dir / file)
    return tuple(dict.fromkeys(f.resolve() for f in files))


def _map_image(map_yaml: Path) -> list[Path]:
    """The picture a ROS map YAML names (none when it cannot be read: nothing is written
    then, the command fails on the map first)."""
    from tinyrace.tracks.csv_rows import read_text
    from tinyrace.tracks.ros_map import read_info

    try:
        return [read_info(map_yaml, read_text(map_yaml, str(map_yaml), "file"), True).image]
    except ConfigError:
        return []


def check_output(output: Path, inputs: tuple[Path, ...], force: bool) -> None:
    """Refuse to write where the user's files are.

    Never over a file the command read (even with ``force``); without ``force``, never over
    an existing file and never into a track folder (one holding a track.yaml) or below one.
    """
    try:
        _check_output(output, inputs, force)
    except ConfigError:
        raise  # its own message, never quoted inside another
    except (OSError, ValueError) as exc:  # a name too long, a NUL byte, no permission
        allowed = f"a path the system can write ({system_reason(exc)})"
        raise ConfigError(Problem(COMMAND_LINE, "-o/--output", str(output), allowed)) from None


def write_picture(output: Path, data: bytes) -> None:
    """Write ``data`` as ``output`` whole, as a run's files are written: to a temporary file
    renamed over the target, never through a link (another name of the same file keeps
    it), never into a FIFO or device; OpenCV's own writer follows links, blocks on a FIFO,
    removes the target when a write fails and crashes on a name that is not UTF-8."""
    from tinyrace.experiment.files import check_writable, write_file

    where = "-o/--output"
    try:
        check_writable(output)
    except ConfigError as exc:
        raise ConfigError(
            Problem(COMMAND_LINE, where, str(output), exc.problems[0].allowed)
        ) from None
    try:
        write_file(output, data)
    except OSError as exc:
        allowed = f"a path that can be written ({system_reason(exc)})"
        raise ConfigError(Problem(COMMAND_LINE, where, str(output), allowed)) from None


def system_reason(exc: BaseException) -> str:
    """Why the system refused a path, short (an OSError's text repeats the whole path)."""
    reason = getattr(exc, "strerror", None) or str(exc)
    text = f"{type(exc).__name__}: {reason}"
    return text if len(text) <= 160 else text[:157] + "..."


PICTURE_SUFFIXES = (".png", ".jpg", ".jpeg")


def track_folder_holding(path: Path) -> Path | None:
    """The nearest folder at or above ``path`` that holds a track.yaml, or None."""
    folders = (path, *path.parents) if path.is_dir() else path.parents
    return next((f for f in folders if (f / TRACK_FILE).is_file()), None)


def _another_name_of(output: Path, inputs: tuple[Path, ...]) -> bool:
    """Whether ``output`` is a hard link to one of ``inputs`` (the same file by another name)."""
    if not output.is_file():
        return False
    return any(path.is_file() and os.path.samefile(output, path) for path in inputs)


def _check_output(output: Path, inputs: tuple[Path, ...], force: bool) -> None:
    where = "-o/--output"
    if output.suffix.lower() not in PICTURE_SUFFIXES:
        allowed = f"a picture file name ending in {', '.join(PICTURE_SUFFIXES)}"
        raise ConfigError(Problem(COMMAND_LINE, where, str(output), allowed))
    resolved = output.resolve()
    if resolved in inputs or _another_name_of(output, inputs):
        allowed = "a path that is not one of the files this command reads: choose another -o"
        raise ConfigError(Problem(COMMAND_LINE, where, str(output), allowed))
    if resolved.is_dir():
        raise ConfigError(Problem(COMMAND_LINE, where, str(output), "a file path, not a folder"))
    if force:
        return
    if resolved.exists() or resolved.is_symlink():
        allowed = "a path that does not exist yet (or --force to replace the file)"
        raise ConfigError(Problem(COMMAND_LINE, where, str(output), allowed))
    track_folders = [p.parent for p in inputs if p.name == TRACK_FILE]
    inside = next((f for f in track_folders if resolved.is_relative_to(f)), None)
    inside = inside or track_folder_holding(resolved)
    if inside is not None:
        allowed = (
            f"expected a path outside the track folder {inside}, which holds {TRACK_FILE} "
            "(this one is inside it): give -o elsewhere, or --force"
        )
        raise ConfigError(Problem(COMMAND_LINE, where, str(output), allowed))
