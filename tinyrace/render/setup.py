"""The pictures of an env's tracks, drawn on the episode's ground: chosen by that ground,
which ``tinyrace.ground.grounds.make_ground`` chose by what the tracks hold, never by their
kind."""

from __future__ import annotations

from tinyrace.config import EnvConfig
from tinyrace.ground.grounds import EpisodeGround, ImageGround, MetricGround, ProceduralGround
from tinyrace.render.image_pictures import ImagePictures
from tinyrace.render.metric_pictures import MetricPictures
from tinyrace.render.pictures import Pictures
from tinyrace.render.procedural_pictures import ProceduralPictures
from tinyrace.sensors.machinery.draw_cars import CarLooks


def make_pictures(config: EnvConfig, ground: EpisodeGround) -> Pictures:
    """The pictures of the tracks whose ground is ``ground`` (made once per env; ``reset``
    per episode): CarRacing's chase views on a ground painted anew for each track, the
    overview of tracks that carry a picture, or the overview (and default top view) of a
    ground drawn once per track from what it holds."""
    if isinstance(ground, ProceduralGround):
        return ProceduralPictures(ground, CarLooks.of(config))
    if isinstance(ground, ImageGround):
        return ImagePictures(config, ground)
    if isinstance(ground, MetricGround):
        return MetricPictures(config, ground)
    raise TypeError(f"no pictures for a ground of type {type(ground).__name__}")
