"""The pictures of an episode, one class per track kind, drawn from a snapshot and the track.

A ``Pictures`` object lasts across resets (it keeps what is dear to redraw: ground
textures, dashboards, car patches); ``reset`` points it at a new episode's track. It
draws the observation of an env without sensors, the render modes' frames and the
ground the cameras see. It never touches the world: it reads the ``Snapshot``, the
``Track`` and the tiles the episode's rules have marked visited.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from tinyrace.sensors.texture import GroundTexture
from tinyrace.tracks.base import TrackDraw
from tinyrace.world.snapshot import Snapshot

CameraViews = Sequence[tuple[np.ndarray, np.ndarray]]  # per camera: (image, window corners)


class Pictures(Protocol):
    """What the env asks of a track kind's pictures."""

    def reset(self, draw: TrackDraw, visited: Sequence[int]) -> None:
        """A new episode on ``draw``'s track; ``visited``: its tiles in the order the rules
        mark them (the episode's list, read as it grows)."""

    def observe(self, snapshot: Snapshot, score: float) -> np.ndarray:
        """The observation of an env without sensors."""
        ...

    def frame(
        self, mode: str, snapshot: Snapshot, score: float, cameras: CameraViews = ()
    ) -> np.ndarray:
        """The picture of render mode ``mode``; ``cameras``: each camera's image and window."""
        ...

    def ground_texture(self) -> GroundTexture:
        """The ground the cameras see now."""
        ...
