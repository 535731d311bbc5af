"""The pictures of an env's tracks, drawn on the episode's ground: chosen by what that
ground offers (``tinyrace.ground.grounds.EpisodeGround``), never by its class or the
tracks' kind."""

from __future__ import annotations

from tinyrace.config import EnvConfig
from tinyrace.ground.grounds import EpisodeGround
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
    rescalable = ground.rescalable()
    if rescalable is not None:
        return ProceduralPictures(rescalable, CarLooks.of(config))
    if ground.carries_pictures:
        return ImagePictures(config, ground)
    return MetricPictures(config, ground)
