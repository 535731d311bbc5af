"""Reading and validating an experiment file, with the env it describes."""

from __future__ import annotations

import dataclasses
import importlib.util
import sys
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

from tinyrace.config import TRACK_FILE, EnvConfig, LoadedConfig, Overrides, load_env_config
from tinyrace.config.experiment import ExperimentConfig
from tinyrace.config.load import EXPERIMENT_KEYS
from tinyrace.config.loader import Parser, read_yaml
from tinyrace.config.paths import inside_folder
from tinyrace.config.yaml_file import document_kind
from tinyrace.errors import ConfigError, Problem, did_you_mean, one_of
from tinyrace.examples import shipped_track

ENV_FOLDER_KEY = "environment"  # inside ``env``: a track folder or track.yaml


@dataclass(frozen=True)
class Experiment:
    """A validated experiment and the keyword arguments that make its env."""

    config: ExperimentConfig
    source: str  # the file, for messages and the run directory's name
    env_config: EnvConfig
    env_kwargs: dict[str, Any]  # for TinyRaceEnv(**env_kwargs) or gym.make
    loaded: LoadedConfig  # the env config, its problems named in the experiment or track file
    folder: Path = Path()  # the experiment file's folder: own drivers are imported from it
    agents: tuple[str, ...] = ("car_0",)  # the env's cars (RaceEnv.possible_agents)

    @property
    def is_race(self) -> bool:
        """Several cars, each with its driver (run by ``race_runner``)."""
        return len(self.agents) > 1

    @property
    def name(self) -> str:
        """The run folders' name: the experiment file's, or the track folder's."""
        path = Path(self.source)
        if path.name == TRACK_FILE:
            return path.parent.name
        return path.stem if self.source.endswith((".yaml", ".yml")) else "experiment"


def is_experiment(raw: object) -> bool:
    """An experiment file has experiment keys; a track.yaml has track sections."""
    return isinstance(raw, Mapping) and bool(EXPERIMENT_KEYS & set(raw))


def load_experiment(path: str | Path) -> Experiment:
    """Read ``path``; every problem (experiment keys and env keys) raises one ConfigError."""
    path = Path(path)
    raw = read_yaml(path)
    return experiment_from_dict(raw if raw is not None else {}, str(path), path.parent)


def experiment_from_dict(raw: object, source: str, base_dir: Path) -> Experiment:
    """The experiment of ``raw`` (read from ``source``); one ConfigError lists every problem
    found: of the experiment's keys, its env's (named in the file each came from) and, when
    there are any, also those found by building the env (its files, car, sensors)."""
    parser = Parser(source)
    config = parser.dataclass(ExperimentConfig, raw, "")
    if not parser.parsed(config):  # not a mapping: nothing more to read
        parser.check()
    problems = [*parser.problems, *driver_problems(config.driver, base_dir, source)]
    sections = dict(config.env)
    track_path = sections.pop(ENV_FOLDER_KEY, None)
    try:
        loaded, kwargs = _load_env(sections, track_path, base_dir, source)
    except ConfigError as exc:
        raise ConfigError(problems + exc.problems) from None
    # its files, car, sensors (a fixed track is loaded once: the run's env shares it)
    built, agents = _build(loaded)
    if len(agents) <= 1:
        problems += view_problems(config, loaded.config, source)
    problems += built
    problems += race_problems(config, agents, base_dir, source)
    if problems:
        raise ConfigError(problems)
    return Experiment(config, source, loaded.config, kwargs, loaded, base_dir, agents)


def _load_env(
    sections: dict[str, Any], track_path: object, base_dir: Path, source: str
) -> tuple[LoadedConfig, dict[str, Any]]:
    """The env of an experiment's ``env:`` (a track file and/or inline sections)."""
    if track_path is None:  # inline sections: their files are read beside the experiment
        sections = _absolute_images(sections, base_dir, source)
        overrides = Overrides(sections, source, "env.")
        loaded = dataclasses.replace(load_env_config(overrides=overrides), base_dir=base_dir)
        return loaded, {"config": loaded}
    track_file = _track_file(track_path, base_dir, source)
    loaded = load_env_config(config=track_file, overrides=Overrides(sections, source, "env."))
    return loaded, {"config": str(track_file), **sections}


def build_problems(loaded: LoadedConfig) -> list[Problem]:
    """The problems found by building the env of ``loaded`` (files, car model, sensors)."""
    return _build(loaded)[0]


def _build(loaded: LoadedConfig) -> tuple[list[Problem], tuple[str, ...]]:
    """``build_problems``, and the names of the env's cars (a race's: RaceEnv's agents)."""
    from tinyrace.env import TinyRaceEnv
    from tinyrace.race import RaceEnv

    several = (
        loaded.config.race.num_agents > 1 or len(getattr(loaded.config, "cars", None) or ()) > 1
    )
    try:
        if not several:
            TinyRaceEnv(config=loaded).close()
            return [], ("car_0",)
        race = RaceEnv(config=cast(Any, loaded))  # a LoadedConfig, as TinyRaceEnv takes it
        race.close()
    except ConfigError as exc:
        return exc.problems, ()
    return [], tuple(race.possible_agents)


def race_problems(
    config: ExperimentConfig, agents: tuple[str, ...], folder: Path, source: str
) -> list[Problem]:
    """The problems of ``drivers`` (a driver per car of a race) and, in a race, of
    ``output.view`` (its one video shows every car: the overview)."""
    from tinyrace.experiment.race_drivers import car_drivers

    if not agents:  # the env was not built: its problems are reported
        return []
    if len(agents) == 1:
        if not config.drivers:
            return []
        allowed = "expected no per-car drivers for one car (race.num_agents 1): set 'driver'"
        return [Problem(source, "drivers", dict(config.drivers), allowed)]
    drivers, problems = car_drivers(config, agents, source)
    for driver in drivers:
        if driver.key != "driver":  # the default driver is checked once, as 'driver'
            problems += driver_problems(driver.spec, folder, source, driver.key, driver.agent)
    if config.output.view != "default":
        allowed = "expected default: a race's video is the overview of every car"
        problems.append(Problem(source, "output.view", config.output.view, allowed))
    return problems


_IMAGE_SENSORS = ("birdseye_camera", "perspective_camera")  # their observation is a picture


def check_view(config: ExperimentConfig, env_config: EnvConfig, source: str) -> None:
    """``output.view`` is ``default``, ``sensors`` (with a ``sensors:`` list) or the id of
    one of the env's cameras (checked at validate)."""
    problems = view_problems(config, env_config, source)
    if problems:
        raise ConfigError(problems)


def view_problems(config: ExperimentConfig, env_config: EnvConfig, source: str) -> list[Problem]:
    """The problem of ``output.view``, if any (see ``check_view``)."""
    view = config.output.view
    ids = [c.id for c in env_config.cameras]
    written = env_config.written_sensors  # its cameras are listed above
    ids += [s.id for s in written if s.type in _IMAGE_SENSORS]
    views = ["default", *(["sensors"] if written else []), *ids]
    if view in views:
        return []
    allowed = f"{did_you_mean(view, views)}one of: {', '.join(views)}"
    return [Problem(source, "output.view", view, allowed)]


def driver_problems(
    spec: str, folder: Path, source: str, key: str = "driver", car: str | None = None
) -> list[Problem]:
    """The problem of the ``driver`` key (or ``key``, the driver of ``car`` in a race), if
    any: a built-in driver name, or ``module:callable`` with the module found from ``folder``.

    The module is looked up, not run (a dotted name imports its parent package).
    """
    from tinyrace.drivers import DRIVERS

    whose = f"car {car}'s driver: " if car is not None else ""
    if ":" not in spec:
        if spec in DRIVERS:
            return []
        allowed = f"{whose}{one_of(spec, DRIVERS)}, or module:callable"
        return [Problem(source, key, spec, allowed)]
    module, _, attribute = spec.partition(":")
    if not (all(p.isidentifier() for p in module.split(".")) and attribute.isidentifier()):
        allowed = f"{whose}expected module:callable made of Python names (e.g. my_policy:make)"
        return [Problem(source, key, spec, allowed)]
    with importable_from(folder):
        try:
            found = importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):
            found = False
    if not found:
        where = f"in {folder} or on the Python path"
        allowed = f"{whose}expected module:callable with the module {where}"
        return [Problem(source, key, spec, allowed)]
    return []


@contextmanager
def importable_from(folder: Path) -> Iterator[None]:
    """Modules in ``folder`` (an experiment's folder) can be imported inside this block."""
    entry = str(folder.resolve())
    sys.path.insert(0, entry)
    try:
        yield
    finally:
        sys.path.remove(entry)


def _track_file(value: object, base_dir: Path, source: str) -> Path:
    """``env.environment``: a track folder or its track.yaml, relative to the experiment."""
    where = f"env.{ENV_FOLDER_KEY}"
    if not isinstance(value, str):
        raise ConfigError(
            Problem(source, where, value, "expected a track folder or track.yaml path")
        )
    try:
        path = (base_dir / value).resolve()
        if path.is_dir():
            path = path / TRACK_FILE
        found = path.is_file()
    except (OSError, ValueError):  # a name the file system cannot hold (too long, NUL byte)
        found = False
    if not found:  # a shipped track's bare name, or an error listing them
        return shipped_track(value, source, where) / TRACK_FILE
    document = read_yaml(path)  # invalid YAML: named in its own file
    if document is not None and not isinstance(document, Mapping):
        allowed = (
            f"expected a track folder or a track.yaml of sections (sim, track, car, ...): "
            f"{path} holds {document_kind(document)}"
        )
        raise ConfigError(Problem(source, where, value, allowed))
    return path


def _absolute_images(sections: dict[str, Any], base_dir: Path, source: str) -> dict[str, Any]:
    """Inline track images are relative to the experiment file (and stay in its folder unless
    ``files.paths_outside_folder``): make them absolute."""
    files = sections.get("files")
    outside = isinstance(files, Mapping) and files.get("paths_outside_folder") is True
    for key in ("track", "tracks"):
        tracks = sections.get(key)
        entries = (
            [tracks] if isinstance(tracks, Mapping) else tracks if isinstance(tracks, list) else []
        )
        resolved = []
        for index, entry in enumerate(entries):
            if isinstance(entry, Mapping) and isinstance(entry.get("image"), str):
                where = f"env.{key}[{index}].image"
                image = inside_folder(entry["image"], base_dir, outside, source, where)
                entry = {**entry, "image": str(image)}
            resolved.append(entry)
        if entries:
            sections = {**sections, key: resolved[0] if isinstance(tracks, Mapping) else resolved}
    return sections
