"""Reading a config: a track folder, a YAML path, a dict or ``gym.make``'s keywords, with
overrides laid over it, parsed and checked into a ``LoadedConfig``."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

from tinyrace.config.camera_info import with_camera_info
from tinyrace.config.car_models import car_models
from tinyrace.config.checks import CAR_KNOB_DEFAULTS, check_consistency
from tinyrace.config.defaults import resolve_defaults
from tinyrace.config.loader import Parser, deep_merge, read_yaml
from tinyrace.config.overrides import (
    DEFAULTS,
    KWARGS,
    Overrides,
    blame,
    spelled_as,
    spelling_of,
)
from tinyrace.config.race import inherited, lay_cars_over_car, resolve_race_cars
from tinyrace.config.schema import EnvConfig
from tinyrace.config.yaml_file import document_kind
from tinyrace.errors import ConfigError, Problem, did_you_mean
from tinyrace.examples import find_track, track_names

TRACK_FILE = "track.yaml"


@dataclass(frozen=True)
class LoadedConfig:
    """A validated config, with where it came from (for errors) and where its images live."""

    config: EnvConfig
    source: str  # file path or "<dict>", used in error messages
    base_dir: Path  # images are relative to this
    overrides: Overrides = dataclasses.field(default_factory=Overrides)  # laid over ``source``
    # how the file writes its list sections (``track: {...}`` or ``tracks: [...]``)
    spelling: Mapping[str, tuple[str, bool]] = dataclasses.field(default_factory=dict)

    def blame(self, problems: list[Problem]) -> list[Problem]:
        """Each problem named where its value came from: a key given as an override names
        the overrides' source (a keyword argument, the experiment file), not the track file;
        a key of the file is named as the file writes it (``track.file``, not ``tracks[0]``)."""
        return blame(problems, self.source, self.overrides, self.spelling)


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
        config, laid = None, _config_over_folder(config, environment, laid)
    raw, source, base_dir = _read_source(cast(_Source, config), environment)
    if laid.keys:
        raw = deep_merge(_without_its_car_knobs(raw, laid.keys), spelled_as(laid.keys, raw))
    if environment is not None and "tracks" not in raw and "track" not in raw:
        raw["tracks"] = [{}]  # a tinycarlo folder without tracks: its empty black plane
    spelling = spelling_of(raw)
    try:
        parsed = with_camera_info(parse_env_config(raw, source), source, base_dir)
    except ConfigError as exc:
        raise ConfigError(blame(exc.problems, source, laid, spelling)) from None
    return LoadedConfig(parsed, source, base_dir, laid, spelling)


_Source = str | Path | Mapping[str, Any] | None  # what _read_source reads


def _config_over_folder(config: Any, environment: str | Path, laid: Overrides) -> Overrides:
    """``config=`` (a YAML path or a dict) given with ``environment=``: its keys laid over
    the folder's track.yaml like keyword arguments, which in turn override them."""
    if isinstance(config, LoadedConfig):
        allowed = "give a YAML path or a dict as config= with environment= (not a loaded one)"
        raise ConfigError(Problem(KWARGS, "environment", str(environment), allowed))
    raw, source, _ = _read_source(config, None)
    keys = deep_merge(raw, spelled_as(laid.keys, raw))
    named = f"{source} + {laid.source}" if laid.keys else source  # where a bad key came from
    return Overrides(keys, named, laid.prefix)


def _without_its_car_knobs(raw: dict[str, Any], keys: Mapping[str, Any]) -> dict[str, Any]:
    """``raw`` without the knobs of its car section that no car reads once the overrides
    choose other car models (``car={"model": "single_track"}``, or a ``race.cars`` list of
    such cars, on a track whose file sizes a kinematic car): other cars, not the file's car
    with knobs they would refuse. Knobs some car reads stay laid under the overrides'."""
    own = raw.get("car")
    if not isinstance(own, Mapping) or not _chosen_models(keys):
        return raw
    merged = deep_merge(raw, spelled_as(keys, raw))
    names = _chosen_models(merged, every_car=True)
    if names is None or set(names) <= set(_chosen_models(raw, every_car=True) or ()):
        return raw  # a car of the default model, or no model the file did not have already
    models = [car_models().get(name) for name in names]
    if any(model is None or model.reads is None for model in models):
        return raw  # an unknown model (named by the checks), or one that reads every knob
    reads = set().union(*(model.reads or () for model in models if model is not None))
    kept = {k: v for k, v in own.items() if k not in CAR_KNOB_DEFAULTS or k in reads}
    return {**raw, "car": kept}


def _chosen_models(raw: Mapping[str, Any], every_car: bool = False) -> list[str] | None:
    """The car models ``raw`` names: its car section's and its ``race.cars`` entries' (with
    ``every_car``: the model of each car of the env, a car without its own that of the car
    section; None when one is left to the track's default or is no name)."""
    top = raw.get("car")
    name = top.get("model") if isinstance(top, Mapping) else None
    race = raw.get("race")
    cars = race.get("cars") if isinstance(race, Mapping) else None
    entries = [cars] if isinstance(cars, Mapping) else cars if isinstance(cars, list) else []
    names = []
    for entry in entries:
        car = entry.get("car") if isinstance(entry, Mapping) else None
        names.append(car.get("model", name) if isinstance(car, Mapping) else name)
    if not every_car:
        return [n for n in [name, *names] if isinstance(n, str)]
    found = names or [name]
    strings = [n for n in found if isinstance(n, str)]
    return strings if len(strings) == len(found) else None


def _read_source(
    config: str | Path | Mapping[str, Any] | None, environment: str | Path | None
) -> tuple[dict[str, Any], str, Path]:
    if environment is not None:
        if not isinstance(environment, (str, Path)):
            allowed = "expected a track folder (a path)"
            raise ConfigError(Problem("<kwargs>", "environment", environment, allowed))
        if isinstance(environment, str) and not environment.strip():  # not the working folder
            allowed = f"expected a track folder or a shipped track: {', '.join(track_names())}"
            raise ConfigError(Problem(KWARGS, "environment", environment, allowed))
        folder = find_track(environment)  # a path that exists wins over a shipped track's name
        config = folder / TRACK_FILE
        if not _safely(lambda: os.path.lexists(config)):  # a FIFO or a folder: read_yaml says
            raise ConfigError(Problem(KWARGS, "environment", str(environment), _no_track(folder)))
    if config is None:
        return {}, DEFAULTS, Path.cwd()
    if isinstance(config, Mapping):
        return dict(config), "<dict>", Path.cwd()
    if not isinstance(config, (str, Path)) or (isinstance(config, str) and not config.strip()):
        # an empty name is no file: Path("") would be the working folder, read as a track folder
        allowed = "expected a YAML file path, a track folder or a mapping (dict)"
        raise ConfigError(Problem(KWARGS, "config", config, allowed))
    path = Path(config)
    if _safely(path.is_dir):
        path = path / TRACK_FILE
    raw = read_yaml(path)
    if raw is None:
        raw = {}
    if not isinstance(raw, Mapping):
        allowed = "expected a YAML mapping of sections (sim, track, car, ...)"
        raise ConfigError(Problem(str(path), "", document_kind(raw), allowed))
    found = sorted(EXPERIMENT_KEYS & set(raw))
    if found:  # its env section alone would be an env config
        allowed = (
            f"expected an env config (sim, track, car, ...); this is an experiment file (it "
            f"has {', '.join(found)}): run it with `tinyrace run {path}`, or give its env: "
            "section as config="
        )
        raise ConfigError(Problem(str(path), found[0], raw[found[0]], allowed))
    return dict(raw), str(path), path.parent


# the top-level keys of an experiment file (tinyrace.experiment), none of an env config's
EXPERIMENT_KEYS = frozenset(
    {"env", "driver", "drivers", "episodes", "output", "driver_args", "max_steps"}
)


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
        check_consistency(config, parser, at, given)
    parser.check()
    return resolve_race_cars(resolve_defaults(config))
