"""The pictures of an env's track kind: one ``Pictures`` class per track source."""

from __future__ import annotations

from tinyrace.config import EnvConfig
from tinyrace.render.image_pictures import ImagePictures
from tinyrace.render.metric_pictures import MetricPictures
from tinyrace.render.pictures import Pictures
from tinyrace.render.procedural_pictures import ProceduralPictures
from tinyrace.tracks.base import TrackSource
from tinyrace.tracks.image import ImageSource
from tinyrace.tracks.metric import MetricSource
from tinyrace.tracks.procedural_source import ProceduralSource


def make_pictures(config: EnvConfig, source: TrackSource) -> Pictures:
    """The pictures of ``source``'s tracks (made once per env; ``reset`` per episode)."""
    if isinstance(source, ProceduralSource):
        return ProceduralPictures(config, source)
    if isinstance(source, MetricSource):
        return MetricPictures(config, source)
    assert isinstance(source, ImageSource), f"no pictures for track kind {source.kind!r}"
    return ImagePictures(config, source)
