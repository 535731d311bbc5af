"""The ground of an env's tracks: the one place that paints and serves the track texture an
episode's sensors and pictures sample.

An ``EpisodeGround`` is made once per env (``make_ground``) and told of each new episode
(``reset``); sensors (``SensorContext.ground``) and pictures (``tinyrace.render``) both ask it
for ``texture(track)``. CarRacing's ground changes during an episode (a visited tile loses its
shade): every texture of the episode is repainted before it is next served.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from tinyrace import cache
from tinyrace.config import EnvConfig, cache_settings
from tinyrace.ground.metric import shared_ground
from tinyrace.ground.procedural import GroundPainter, repaint_tile
from tinyrace.ground.texture import GroundTexture
from tinyrace.tracks.base import PaintedGround, Track, TrackDraw, TrackSource
from tinyrace.tracks.procedural_source import GroundColors


class EpisodeGround(Protocol):
    """The ground textures of an env's tracks, pointed at the current episode by ``reset``."""

    def reset(self, draw: TrackDraw, visited: Sequence[int]) -> None:
        """A new episode on ``draw``'s track; ``visited``: its tiles in the order the rules
        mark them (the episode's list, read as it grows)."""

    def texture(self, track: Track) -> GroundTexture:
        """The ground of ``track`` in the current episode (as the cameras sample it)."""
        ...

    @property
    def tracks(self) -> Sequence[Track]:
        """The fixed tracks it serves, a texture each (none: a track drawn at each reset)."""
        ...

    @property
    def carries_pictures(self) -> bool:
        """Whether its textures are the tracks' own pictures (an overview shows them as
        they are, not a ground drawn from what the tracks hold)."""
        ...

    def rescalable(self) -> Rescalable | None:
        """The ground painted anew at any resolution (render's views at their own sizes),
        or None: one texture per track."""
        ...


class Rescalable(Protocol):
    """A ground painted at any resolution: CarRacing's, painted at each reset."""

    @property
    def painted(self) -> PaintedGround:
        """The playfield and the cameras' pixels_per_unit."""
        ...

    def texture_at(self, pixels_per_unit: float) -> GroundTexture:
        """The ground at ``pixels_per_unit`` now (every tile visited so far repainted)."""
        ...


class ProceduralGround:
    """CarRacing's ground, painted at each reset in the episode's colours, at any number of
    resolutions (the observation's, the videos'), each made when first asked."""

    @classmethod
    def serving(cls, config: EnvConfig, source: TrackSource) -> ProceduralGround | None:
        """CarRacing's ground, for a source that paints each track it makes."""
        return cls(source.painted) if source.painted is not None else None

    def __init__(self, painted: PaintedGround):
        self.painted = painted  # the playfield and the cameras' pixels_per_unit
        self.pixels_per_unit = painted.pixels_per_unit  # [px/u] of the cameras' texture
        self.painter = GroundPainter(painted.playfield)
        self.track: Track | None = None
        self.colors: GroundColors | None = None
        self.visited: Sequence[int] = ()
        self._textures: dict[float, GroundTexture] = {}  # by pixels per unit
        self._painted = 0  # visited tiles repainted on every texture

    tracks: Sequence[Track] = ()  # a new track at each reset
    carries_pictures = False

    def rescalable(self) -> Rescalable | None:
        return self

    def reset(self, draw: TrackDraw, visited: Sequence[int]) -> None:
        self.track, self.colors, self.visited = draw.track, GroundColors.of(draw.track), visited
        self._textures, self._painted = {}, 0

    def texture(self, track: Track) -> GroundTexture:
        """The ground at the track's pixels_per_unit, with every tile visited so far."""
        texture = self._textures.get(self.pixels_per_unit)  # the cameras' (asked every step)
        if texture is None or self._painted < len(self.visited):
            texture = self.texture_at(self.pixels_per_unit)
        return texture

    def texture_at(self, pixels_per_unit: float) -> GroundTexture:
        """The ground at ``pixels_per_unit``, with every tile visited so far repainted."""
        assert self.track is not None and self.colors is not None, "reset() first"
        if self._painted < len(self.visited):
            self._repaint_visited()
        texture = self._textures.get(pixels_per_unit)
        if texture is None:
            texture = self.painter.paint(self.track, self.colors, pixels_per_unit)
            for tile in self.visited[: self._painted]:  # in visit order: the same pixels
                repaint_tile(texture, self.track, tile, self.colors.road)
            self._textures[pixels_per_unit] = texture
        return texture

    def _repaint_visited(self) -> None:
        """Repaint the tiles visited since the last texture was served, in visit order."""
        assert self.track is not None and self.colors is not None, "reset() first"
        for tile in self.visited[self._painted :]:
            for texture in self._textures.values():
                repaint_tile(texture, self.track, tile, self.colors.road)
        self._painted = len(self.visited)

    def __getstate__(self) -> dict[str, Any]:
        """Leave out the textures (tens of MB): they are repainted when next asked."""
        return {**self.__dict__, "_textures": {}, "painter": GroundPainter(self.painter.playfield)}


class ImageGround:
    """The picture each fixed track carries, as a texture (made once per env)."""

    @classmethod
    def serving(cls, config: EnvConfig, source: TrackSource) -> ImageGround | None:
        """The pictures, for a source whose fixed tracks all carry one."""
        tracks = source.tracks
        return cls(tracks) if tracks and all(t.picture is not None for t in tracks) else None

    def __init__(self, tracks: Sequence[Track]):
        self.tracks = tracks
        self.textures = [
            GroundTexture.from_image(_picture(track), exact_colors=True) for track in tracks
        ]
        self.index = 0  # the current episode's track

    def reset(self, draw: TrackDraw, visited: Sequence[int]) -> None:
        self.index = draw.track_index

    def texture(self, track: Track) -> GroundTexture:
        return self.textures[self.index]

    carries_pictures = True

    def rescalable(self) -> Rescalable | None:
        return None


class MetricGround:
    """Every fixed track's ground drawn from what it holds (road, cones, a map's cells) at
    its ``ground_pixels_per_unit``, made at its first read and shared with the other envs of
    the track (``shared_ground``)."""

    @classmethod
    def serving(cls, config: EnvConfig, source: TrackSource) -> MetricGround | None:
        """A ground drawn from what the tracks hold: any source's fixed tracks."""
        return cls(config, source.tracks)

    def __init__(self, config: EnvConfig, tracks: Sequence[Track]):
        self.tracks = tracks
        self.cache: cache.Settings = cache_settings(config)
        self.textures: list[GroundTexture | None] = [None] * len(self.tracks)
        self.index = 0  # the current episode's track

    def reset(self, draw: TrackDraw, visited: Sequence[int]) -> None:
        self.index = draw.track_index

    def texture(self, track: Track) -> GroundTexture:
        """The current track's ground (drawn, or mapped, at its first read)."""
        texture = self.textures[self.index]
        if texture is None:
            texture = shared_ground(self.tracks[self.index], self.cache)
            self.textures[self.index] = texture
        return texture

    carries_pictures = False

    def rescalable(self) -> Rescalable | None:
        return None


class GroundType(Protocol):
    """A kind of ground: made for a track source it serves (else None)."""

    def serving(self, config: EnvConfig, source: TrackSource) -> EpisodeGround | None: ...


# The kinds of ground, the first that serves a source is its ground (the last serves all).
GROUND_TYPES: list[GroundType] = [ProceduralGround, ImageGround, MetricGround]


def make_ground(config: EnvConfig, source: TrackSource) -> EpisodeGround:
    """The ground of ``source``'s tracks (made once per env; ``reset`` per episode): the
    first of ``GROUND_TYPES`` that serves the source, by what it offers, never by its kind:
    a ground painted anew for each track from its tiles and kerbs (``source.painted``), the
    picture each fixed track carries (``Track.picture``), or else a ground drawn once per
    track from what it holds (road, cones, a map's cells)."""
    for ground_type in GROUND_TYPES:
        ground = ground_type.serving(config, source)
        if ground is not None:
            return ground
    raise ValueError(f"no ground serves a {source.kind} source")


def _picture(track: Track) -> np.ndarray:
    assert track.picture is not None, "an image ground is of tracks with a picture"
    return track.picture
