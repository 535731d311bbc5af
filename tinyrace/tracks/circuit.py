"""A closed road in metres, whatever file it came from: centreline, widths, tiles, start.

The centreline, cone-map and ROS-map sources all end here: a loop of points in
driving order with the road's width to each side, resampled evenly, point 0 at the
start. Tiles along it give CarRacing's tile reward and lap rule.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from tinyrace.tracks import polyline


@dataclass(frozen=True, eq=False)
class Circuit:
    """A closed road; arrays are read-only, lengths in metres, y up."""

    centerline: np.ndarray  # (N, 2) [m] evenly spaced, point 0 is the start, in driving order
    widths: np.ndarray  # (N, 2) [m] road width to the right and to the left of each point
    headings: np.ndarray  # (N,) [rad] direction of travel, counter-clockwise from +x
    tiles: np.ndarray  # (N, 4, 2) [m] tile i spans point i to i + 1 (see polyline.tiles)
    length: float  # [m] perimeter of the centreline

    @classmethod
    def build(cls, points: np.ndarray, widths: np.ndarray, spacing: float) -> Circuit:
        """Resample ``points`` (N, 2) with ``widths`` (N, 2) to ``spacing`` [m], keeping point
        0; the heading there is the tangent where a straight meets a curve at the start
        (``polyline.start_heading``, judged on ``points`` as given: at any spacing the
        resampled points on both sides of a corner may lie in line), and the start's tiles
        are square to it."""
        even, even_widths = polyline.resample(points, spacing, widths)
        assert even_widths is not None
        heading = polyline.headings(even)
        heading[0] = polyline.start_heading(np.asarray(points, float), heading)
        arrays = (even, even_widths, heading, polyline.tiles(even, even_widths, heading))
        for array in arrays:
            array.setflags(write=False)
        return cls(*arrays, polyline.perimeter(even))

    def with_widths(self, widths: np.ndarray) -> Circuit:
        """The same centreline with other ``widths`` (N, 2) [m], and the tiles they make."""
        widths = np.array(widths, float)
        tiles = polyline.tiles(self.centerline, widths, self.headings)
        for array in (widths, tiles):
            array.setflags(write=False)
        return dataclasses.replace(self, widths=widths, tiles=tiles)

    @property
    def start_pose(self) -> tuple[float, float, float]:
        """(x [m], y [m], heading [rad]) at point 0, facing the direction of travel."""
        x, y = self.centerline[0]
        return float(x), float(y), float(self.headings[0])

    @property
    def spacing(self) -> float:
        """[m] distance between neighbouring centreline points."""
        return self.length / len(self.centerline)

    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """(left, right) (N, 2) edge points [m]."""
        return polyline.edges(self.centerline, self.widths, self.headings)

    def bounds(self, margin: float = 0.0) -> tuple[float, float, float, float]:
        """(x0, y0, x1, y1) [m] around the road's tiles, grown by ``margin``."""
        corners = self.tiles.reshape(-1, 2)
        (x0, y0), (x1, y1) = corners.min(axis=0), corners.max(axis=0)
        return float(x0 - margin), float(y0 - margin), float(x1 + margin), float(y1 + margin)
