"""What ``tinyrace run NAME_OR_PATH`` (and ``tinyrace train``) runs, from what it is given.

An experiment file (or a shipped experiment's name) is run as written. A track folder, a
track.yaml or an env config YAML (or a shipped track's name) is run with the default
experiment: the ``centerline`` driver, five episodes. A bare ``NAME`` is first
``NAME.yaml`` in the working folder (``tinyrace examples copy NAME .`` leaves the
experiment there, and its track folder ``NAME`` beside it), then the folder ``NAME``,
then the shipped experiment, then the shipped track. Anything else (a folder without a
track.yaml, a run folder) is a ConfigError saying what it is and what was expected.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

from tinyrace.config import TRACK_FILE
from tinyrace.config.loader import read_yaml
from tinyrace.errors import ConfigError, Problem
from tinyrace.examples import find_example
from tinyrace.experiment.load import (
    ENV_FOLDER_KEY,
    Experiment,
    experiment_from_dict,
    is_experiment,
)

COMMAND_LINE = "<command line>"
RUN_FILES = ("results.json", "episodes.csv")  # what a run folder holds
EXPECTED = f"expected an experiment file, a track folder (holding {TRACK_FILE}) or a shipped name"
SHOWN = 5  # names listed of a folder's YAML files or track folders


def load_target(value: str | Path, key: str = "experiment") -> tuple[Experiment, bool]:
    """The experiment that ``value`` names (see the module's docstring), and whether it is a
    track's default experiment (True) or an experiment file's (False)."""
    if not str(value).strip():
        allowed = f"{EXPECTED}, not an empty name"
        raise ConfigError(Problem(COMMAND_LINE, key, str(value), allowed))
    path = find_example(value, key)
    if _is_dir(path):
        track_file = path / TRACK_FILE
        if not _is_file(track_file):
            raise ConfigError(Problem(COMMAND_LINE, key, str(value), not_runnable(path)))
        return track_experiment(track_file), True
    raw = read_yaml(path)  # a missing or unreadable file: its own message
    if raw is None or raw == {}:  # never the defaults in its stead: an empty file is a mistake
        allowed = f"{EXPECTED}; this file is empty (an experiment names at least its env)"
        raise ConfigError(Problem(str(path), "", "an empty file", allowed))
    if isinstance(raw, Mapping) and raw and not is_experiment(raw):
        return track_experiment(path), True  # track sections: a track.yaml or env config
    return experiment_from_dict(raw, str(path), path.parent), False


def track_experiment(track_file: Path) -> Experiment:
    """The default experiment on a track file: the centerline driver, five episodes."""
    raw = {"env": {ENV_FOLDER_KEY: str(track_file.resolve())}}
    return experiment_from_dict(raw, str(track_file), track_file.parent)


def not_runnable(folder: Path) -> str:
    """What a folder without a track.yaml is, and what was expected instead."""
    if all(_is_file(folder / name) for name in RUN_FILES):
        return (
            f"{EXPECTED}; this is a run folder (it holds {' and '.join(RUN_FILES)}): "
            f"tinyrace report {folder} rebuilds its report"
        )
    tracks = _names(p.parent.name for p in folder.glob(f"*/{TRACK_FILE}"))
    experiments = _names(p.name for p in folder.glob("*.yaml") if _is_experiment_file(p))
    found = [f"the experiment files {experiments}"] if experiments else []
    found += [f"the track folders {tracks}"] if tracks else []
    if found:
        return (
            f"{EXPECTED}; this folder holds no {TRACK_FILE} but {' and '.join(found)}: "
            "name one of them"
        )
    return f"{EXPECTED}; this folder holds no {TRACK_FILE} and no experiment file"


def _names(names: Iterable[str]) -> str:
    found = sorted(names)
    more = f" and {len(found) - SHOWN} more" if len(found) > SHOWN else ""
    return ", ".join(found[:SHOWN]) + more


def _is_experiment_file(path: Path) -> bool:
    try:
        return is_experiment(read_yaml(path))
    except ConfigError:  # not YAML, too large: not an experiment to name
        return False


def _is_dir(path: Path) -> bool:
    try:
        return path.is_dir()
    except (OSError, ValueError):
        return False


def _is_file(path: Path) -> bool:
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False
