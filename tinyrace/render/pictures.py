"""The pictures of an episode, one class per track kind, drawn from a snapshot and the track.

A ``Pictures`` object lasts across resets (it keeps what is dear to redraw: dashboards,
car patches, overviews); ``reset`` points it at a new episode's track. It draws the render
modes' frames; the ground it shows is the episode's (``tinyrace.ground.grounds``), the
one the sensors see. It never touches the world: it reads the ``Snapshot``, the ``Track``
and the views the sensors drew this step.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from tinyrace.tracks.base import TrackDraw
from tinyrace.world.snapshot import Snapshot

# per image sensor: (its image, its track window's corners, or None for a view without one)
CameraViews = Sequence[tuple[np.ndarray, np.ndarray | None]]


class Pictures(Protocol):
    """What the env asks of a track kind's pictures."""

    def reset(self, draw: TrackDraw) -> None:
        """A new episode on ``draw``'s track."""

    def frame(self, mode: str, snapshot: Snapshot, cameras: CameraViews = ()) -> np.ndarray:
        """The picture of render mode ``mode``; ``cameras``: each image sensor's view now."""
        ...
