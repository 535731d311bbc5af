"""What ``tinyrace validate`` and ``show`` read: a track folder, a track.yaml or an experiment."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tinyrace.config import METRIC_KINDS, TRACK_FILE, EnvConfig, LoadedConfig, load_env_config
from tinyrace.config.loader import read_yaml
from tinyrace.errors import ConfigError


def load_any(path: Path) -> LoadedConfig:
    """The env config behind a track folder, a track.yaml or an experiment file."""
    from tinyrace.experiment import is_experiment, load_experiment

    if path.is_dir():
        return load_env_config(environment=path)
    raw = read_yaml(path)
    if is_experiment(raw):
        experiment = load_experiment(path)
        kwargs = dict(experiment.env_kwargs)
        config = kwargs.pop("config", None)
        return load_env_config(config=config, overrides=kwargs)
    return load_env_config(config=path)


def build_course(loaded: LoadedConfig):
    """Load everything the env would load at construction (images included)."""
    from tinyrace.env import COURSES

    return COURSES[loaded.config.kind](loaded.config, loaded.base_dir, loaded.source)


def validate_path(path: Path) -> tuple[list[str], str]:
    """Every problem found (as lines), or none and a one-line summary."""
    try:
        loaded = load_any(path)
        build_course(loaded)
    except ConfigError as exc:
        return [str(p) for p in exc.problems], ""
    return [], describe(loaded.config)


def describe(config: EnvConfig) -> str:
    cameras = ", ".join(f"{c.id} {c.resolution[0]}x{c.resolution[1]}" for c in config.cameras)
    return (
        f"{config.kind} track ({len(config.tracks)} track(s)), {config.car.model} car, "
        f"{config.sim.fps:g} fps, cameras: {cameras or 'CarRacing 96x96 view'}"
    )


def picture(target: str, seed: int) -> tuple[np.ndarray, str]:
    """(RGB picture, name) of a track; ``target`` 'procedural' means CarRacing's track."""
    from tinyrace.render.track_picture import image_picture, metric_picture, procedural_picture

    if target == "procedural":
        return procedural_picture(load_env_config().config, seed), f"procedural-seed{seed}"
    path = Path(target)
    loaded = load_any(path)
    name = (path if path.is_dir() or path.name != TRACK_FILE else path.parent).stem
    if loaded.config.kind == "procedural":
        return procedural_picture(loaded.config, seed), f"{name}-seed{seed}"
    course = build_course(loaded)
    if loaded.config.kind in METRIC_KINDS:
        prepared = course.prepared[0]
        return metric_picture(prepared.track, prepared.texture), name
    return image_picture(loaded.config, course.tracks[0]), name
