"""Progress along a reference line read from a file: the tiles the car's rear axle passed
since the last step (forward, on the road) are visited (``tiles``); laps as
``TileProgress``; the cross-track error is the distance to the centreline [m] (``cte``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tinyrace.cars.state import CarState
from tinyrace.episodes.rules.base import TILES, Info, RulePart, TileProgress
from tinyrace.episodes.rules.trajectory_error import CTE
from tinyrace.tracks.base import Track
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import Contacts


class CentrelineProgress(TileProgress):
    """One car's progress along the reference line."""

    REACH = 60.0  # [m] how far along the line the nearest point is searched from the last

    def __init__(self, track: Track, settings: Any = None) -> None:
        circuit = track.circuit
        assert circuit is not None  # a track lists this part only with a reference line
        super().__init__(len(circuit.tiles), track.rules.lap_complete_percent)
        self.circuit = circuit
        self.nearest = -1  # centreline index near the car (-1: search all)
        self.tile = -1  # the tile under the car at the last step (-1: none yet)
        self.cte: float | None = None
        self.on_road = True

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        n = facts.tiles_total = len(self.visited)
        previous, (index, lateral) = self.tile, self._locate(*car.rear_axle)
        self.tile = index
        self.cte = facts.cte = abs(lateral)
        right, left = self.circuit.widths[index]
        self.on_road = bool(-right <= lateral <= left)
        if self.on_road:
            self._visit([index] if previous < 0 else _between(previous, index, n), facts)

    def _locate(self, x: float, y: float) -> tuple[int, float]:
        """(tile index, signed lateral offset [m], + left) of a point, searched near the last."""
        circuit = self.circuit
        points = circuit.centerline
        n = len(points)
        if self.nearest < 0:
            candidates = np.arange(n)
        else:
            reach = max(int(self.REACH / circuit.spacing), 8)  # [points]
            candidates = np.arange(self.nearest - reach, self.nearest + reach) % n
        offsets = points[candidates] - (x, y)
        nearest = int(candidates[np.argmin(np.einsum("ij,ij->i", offsets, offsets))])
        heading = circuit.headings[nearest]
        dx, dy = x - points[nearest, 0], y - points[nearest, 1]
        along = dx * math.cos(heading) + dy * math.sin(heading)
        lateral = -dx * math.sin(heading) + dy * math.cos(heading)
        tile = nearest if along >= 0 else (nearest - 1) % n
        self.nearest = nearest
        return tile, lateral

    def info(self, info: Info) -> None:
        info["tiles_visited"] = self.visited_count
        info["tiles_total"] = len(self.visited)
        info["on_road"] = self.on_road
        if self.cte is not None:
            info["cte"] = self.cte  # [m]


def _between(previous: int, current: int, n: int) -> list[int]:
    """Tiles from ``previous`` to ``current`` going forward (a short way), ``current`` last."""
    forward = (current - previous) % n
    if forward <= n // 4:
        return [(previous + k) % n for k in range(1, forward + 1)] or [current]
    return [current]  # backwards or a jump: only the tile under the car


PART = RulePart(
    "centreline_progress",
    CentrelineProgress,
    terms=(TILES, CTE),
    doc="progress along a reference line from a file",
)
