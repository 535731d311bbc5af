"""Reading and validating an experiment file, with the env it describes."""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tinyrace.config import (
    METRIC_KINDS,
    TRACK_FILE,
    EnvConfig,
    LoadedConfig,
    load_env_config,
    parse_env_config,
)
from tinyrace.config.experiment import ExperimentConfig
from tinyrace.config.loader import Parser, deep_merge, read_yaml
from tinyrace.config.paths import inside_folder
from tinyrace.errors import ConfigError, Problem
from tinyrace.examples import shipped_track

ENV_FOLDER_KEY = "environment"  # inside ``env``: a track folder or track.yaml


@dataclass(frozen=True)
class Experiment:
    """A validated experiment and the keyword arguments that make its env."""

    config: ExperimentConfig
    source: str  # the file, for messages and the run directory's name
    env_config: EnvConfig
    env_kwargs: dict[str, Any]  # for TinyRaceEnv(**env_kwargs)
    folder: Path = Path()  # the experiment file's folder: own drivers are imported from it

    @property
    def name(self) -> str:
        return Path(self.source).stem if self.source.endswith((".yaml", ".yml")) else "experiment"


def is_experiment(raw: object) -> bool:
    """An experiment file has experiment keys; a track.yaml has track sections."""
    keys = {"env", "driver", "episodes", "output", "driver_args", "max_steps"}
    return isinstance(raw, Mapping) and bool(keys & set(raw))


def load_experiment(path: str | Path) -> Experiment:
    """Read ``path``; every problem (experiment keys and env keys) raises one ConfigError."""
    path = Path(path)
    raw = read_yaml(path)
    return experiment_from_dict(raw if raw is not None else {}, str(path), path.parent)


def experiment_from_dict(raw: object, source: str, base_dir: Path) -> Experiment:
    parser = Parser(source)
    config = parser.dataclass(ExperimentConfig, raw, "")
    parser.check()
    check_driver(config.driver, base_dir, source)
    sections = dict(config.env)
    track_path = sections.pop(ENV_FOLDER_KEY, None)
    kwargs: dict[str, Any] = {}
    if track_path is None:
        merged = sections = _absolute_images(sections, base_dir, source)
    else:
        track_file = _track_file(track_path, base_dir, source)
        load_env_config(config=track_file)  # its own problems, named in its own file
        merged = deep_merge(read_yaml(track_file) or {}, sections)
        kwargs["config"] = str(track_file)
    env_config = parse_env_config(merged, source, prefix="env")
    check_view(config, env_config, source)
    env_kwargs = {**kwargs, **sections}
    if track_path is None and env_config.kind in METRIC_KINDS:
        # inline metric tracks: their files are read relative to the experiment file, and
        # problems found when they are read name it
        env_kwargs = {"config": LoadedConfig(env_config, source, base_dir)}
    return Experiment(config, source, env_config, env_kwargs, base_dir)


_IMAGE_SENSORS = ("birdseye_camera", "perspective_camera")  # their observation is a picture


def check_view(config: ExperimentConfig, env_config: EnvConfig, source: str) -> None:
    """``output.view`` is ``default``, ``sensors`` (with a ``sensors:`` list) or the id of
    one of the env's cameras (checked at validate)."""
    view = config.output.view
    ids = [c.id for c in env_config.cameras]
    ids += [s.id for s in env_config.sensors if s.type in _IMAGE_SENSORS]
    views = ["default", *(["sensors"] if env_config.sensors else []), *ids]
    if view not in views:
        allowed = f"one of: {', '.join(views)}"
        raise ConfigError(Problem(source, "output.view", view, allowed))


def check_driver(spec: str, folder: Path, source: str) -> None:
    """A built-in driver name, or ``module:callable`` with the module found from ``folder``.

    The module is looked up, not run (a dotted name imports its parent package).
    """
    from tinyrace.drivers import DRIVERS

    if ":" not in spec:
        if spec not in DRIVERS:
            allowed = f"expected one of: {', '.join(sorted(DRIVERS))}, or module:callable"
            raise ConfigError(Problem(source, "driver", spec, allowed))
        return
    module, _, attribute = spec.partition(":")
    if not (all(p.isidentifier() for p in module.split(".")) and attribute.isidentifier()):
        allowed = "expected module:callable made of Python names (e.g. my_policy:make)"
        raise ConfigError(Problem(source, "driver", spec, allowed))
    with importable_from(folder):
        try:
            found = importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):
            found = False
    if not found:
        allowed = f"expected module:callable with the module in {folder} or on the Python path"
        raise ConfigError(Problem(source, "driver", spec, allowed))


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
    return path


TRACK_FILE_KEYS = ("image", "file", "waypoints")  # the files a track entry names


def _check_exists(path: Path, value: str, source: str, where: str) -> None:
    try:
        found = path.is_file()
    except (OSError, ValueError):  # a name the file system cannot hold
        found = False
    if not found:
        allowed = f"expected an existing file, relative to {Path(source).name}: {path} is none"
        raise ConfigError(Problem(source, where, value, allowed))


def _absolute_images(sections: dict[str, Any], base_dir: Path, source: str) -> dict[str, Any]:
    """Inline track files (images, CSVs, map YAMLs) are relative to the experiment file (and
    stay in its folder unless ``files.paths_outside_folder``): make them absolute."""
    files = sections.get("files")
    outside = isinstance(files, Mapping) and files.get("paths_outside_folder") is True
    for key in ("track", "tracks"):
        tracks = sections.get(key)
        entries = (
            [tracks] if isinstance(tracks, Mapping) else tracks if isinstance(tracks, list) else []
        )
        resolved = []
        for index, entry in enumerate(entries):
            for name in TRACK_FILE_KEYS:
                if isinstance(entry, Mapping) and isinstance(entry.get(name), str):
                    where = f"env.{key}[{index}].{name}"
                    found = inside_folder(entry[name], base_dir, outside, source, where)
                    _check_exists(found, entry[name], source, where)
                    if name == "image":  # metric files stay relative: see _metric_kwargs
                        entry = {**entry, name: str(found)}
            resolved.append(entry)
        if entries:
            sections = {**sections, key: resolved[0] if isinstance(tracks, Mapping) else resolved}
    return sections
