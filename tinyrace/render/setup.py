"""The pictures of an env's tracks, chosen by what the tracks hold, never by their kind."""

from __future__ import annotations

from tinyrace.config import EnvConfig
from tinyrace.render.image_pictures import ImagePictures
from tinyrace.render.metric_pictures import MetricPictures
from tinyrace.render.pictures import Pictures
from tinyrace.render.procedural_pictures import ProceduralPictures
from tinyrace.tracks.base import TrackSource


def make_pictures(config: EnvConfig, source: TrackSource) -> Pictures:
    """The pictures of ``source``'s tracks (made once per env; ``reset`` per episode): a
    ground painted anew for each track from its tiles and kerbs (``source.painted``), the
    picture each fixed track carries (``Track.picture``), or else a ground drawn once per
    track from what it holds (road, cones, a map's cells)."""
    if source.painted is not None:
        return ProceduralPictures(source.painted)
    if source.tracks and all(track.picture is not None for track in source.tracks):
        return ImagePictures(config, source.tracks)
    return MetricPictures(config, source.tracks)
