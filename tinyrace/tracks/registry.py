"""The track sources by ``track.type``. To add one, see ``tinyrace/tracks/base.py``."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from tinyrace.cache import shared
from tinyrace.cache.digest import digest
from tinyrace.config import EnvConfig
from tinyrace.errors import ConfigError, Problem
from tinyrace.tracks.base import TrackSource
from tinyrace.tracks.image import ImageSource
from tinyrace.tracks.metric import MetricSource
from tinyrace.tracks.procedural_source import ProceduralSource

SourceBuilder = Callable[[EnvConfig, Path, str], TrackSource]

TRACK_SOURCES: dict[str, SourceBuilder] = {
    "procedural": ProceduralSource,
    "image": ImageSource,
    "centerline": MetricSource,
    "cone_map": MetricSource,
    "ros_map": MetricSource,
}


def make_track_source(config: EnvConfig, base_dir: Path, source: str) -> TrackSource:
    """The source of the config's tracks (all of one kind), with every file loaded.

    A source of fixed tracks (not procedural) is shared: while an env of this process
    holds one whose tracks have the same content (``tinyrace.cache``), that one is returned
    and the one just loaded is dropped. Its arrays are read-only."""
    build = TRACK_SOURCES.get(config.kind)
    if build is None:
        allowed = f"expected a track type, one of: {', '.join(sorted(TRACK_SOURCES))}"
        raise ConfigError(Problem(source, "tracks[0].type", config.kind, allowed))
    loaded = build(config, base_dir, source)
    if not loaded.tracks:  # tracks made anew at every reset stay with their env
        return loaded
    key = ("track source", type(loaded).__qualname__, digest(loaded.tracks))
    return shared(key, lambda: loaded)
