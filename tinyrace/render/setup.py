"""The pictures of an env's track kind: one ``Pictures`` class per kind, keyed by name."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from tinyrace.config import METRIC_KINDS, EnvConfig
from tinyrace.render.image_pictures import ImagePictures
from tinyrace.render.metric_pictures import MetricPictures
from tinyrace.render.pictures import Pictures
from tinyrace.render.procedural_pictures import ProceduralPictures
from tinyrace.sensors.ground import EpisodeGround
from tinyrace.tracks.base import TrackSource

# track.type -> its pictures, built from the config and the episode's ground
PICTURES: dict[str, Callable[[EnvConfig, Any], Pictures]] = {
    "procedural": ProceduralPictures,
    "image": ImagePictures,
    **dict.fromkeys(METRIC_KINDS, MetricPictures),
}


def make_pictures(config: EnvConfig, source: TrackSource, ground: EpisodeGround) -> Pictures:
    """The pictures of ``source``'s tracks on ``ground`` (made once per env; ``reset`` per
    episode)."""
    build = PICTURES.get(source.kind)
    if build is None:
        raise KeyError(f"no pictures for track kind {source.kind!r}; known: {', '.join(PICTURES)}")
    return build(config, ground)
