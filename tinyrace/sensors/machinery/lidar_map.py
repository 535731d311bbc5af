"""What stops a lidar's beams: the track's blocking layers drawn into a grid once per track.

``blocking_map`` is the sampled field of any track (off-road, walls, obstacle colours,
cones); ``occupancy_map`` the exact field of a ROS map, one cell per pixel. Each cell keeps
the class of what a beam there hits: 0 nothing, 1 a wall, 1 + k a cone of class k
(``tracks.cone_map.CLASSES``).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from tinyrace.sensors.machinery.common import RGB, color_mask, fill_quads, grid
from tinyrace.sensors.machinery.raycast import DistanceField, distance_field
from tinyrace.sensors.machinery.raycast_exact import ExactField, exact_field
from tinyrace.tracks.base import Track
from tinyrace.tracks.cone_map import CLASSES, RADII

NO_HIT, WALL_CLASS = 0, 1  # hit classes; a cone of class k is WALL_CLASS + k
CONE_RADII = np.array([0.0, *(RADII[name] for name in CLASSES)])  # [m] by cone class id


def blocking_map(
    track: Track,
    blocks: tuple[str, ...],
    cell: float,
    cone_colors: tuple[RGB, ...],
    classes: bool = False,
    reach: float = math.inf,
    near: bool = True,
) -> DistanceField:
    """The field of what ``blocks`` names on ``track``, ``cell`` [track units] per
    cell: off_road (outside the road surfaces, on tracks that have them), walls (a ROS map's
    occupied cells), obstacles (picture tracks' obstacle colours), cones (the track's cones,
    e.g. a cone map's, or the picture's cone colours, ``cone_colors`` by class id - 1).
    ``classes``: keep each blocking cell's hit class for ``hit_classes``; ``reach`` [track
    units] the longest range it serves; ``near``: for the numpy passes (else the compiled
    kernel's, see ``distance_field``)."""
    to_cells, (w, h), cell = grid(track, cell)
    labels = np.zeros((h, w), np.uint8)  # hit class of each cell, 0 free
    roads = [s.quads for s in track.surfaces if s.name == "road"]
    if "off_road" in blocks and roads:
        labels[:] = WALL_CLASS
        for quads in roads:
            fill_quads(labels, to_cells, quads, NO_HIT)
    if "walls" in blocks:
        fill_quads(labels, to_cells, track.wall_quads, WALL_CLASS)
    if "cones" in blocks and len(track.cones):
        _draw_cones(labels, to_cells, track, 1.0 / cell)
    if track.picture is not None:
        colors = [layer.color for layer in track.obstacles] if "obstacles" in blocks else []
        picture = _picture_labels(track.picture, colors, cone_colors if "cones" in blocks else ())
        if picture.shape != labels.shape:
            picture = _pool_max(picture, (w, h))
        labels = np.where(picture > 0, picture, labels)
    return distance_field(labels > 0, to_cells, labels if classes else None, reach / cell, near)


def occupancy_map(
    track: Track, blocks: tuple[str, ...], classes: bool = False
) -> ExactField | None:
    """The exact field of a ROS map track (None on other tracks): one cell per pixel of the
    map, aligned with the pixels' edges; walls are the occupied pixels themselves, cones
    discs of their radius, off_road what lies outside the road tiles (a band around the
    waypoints)."""
    occupancy = track.occupancy
    if occupancy is None:
        return None
    to_cells = occupancy.to_cells()
    height, width = occupancy.shape
    labels = np.zeros((height, width), np.uint8)
    roads = [s.quads for s in track.surfaces if s.name == "road"]
    if "off_road" in blocks and roads:
        labels[:] = WALL_CLASS
        for quads in roads:
            fill_quads(labels, to_cells, quads, NO_HIT)
    if "walls" in blocks:
        labels[occupancy.occupied] = WALL_CLASS
    if "cones" in blocks and len(track.cones):
        _draw_cones(labels, to_cells, track, 1.0 / occupancy.info.resolution)
    return exact_field(labels > 0, to_cells, labels if classes else None)


def _pool_max(labels: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(h, w) uint8: the largest label among the pixels of each cell of a ``size`` (w, h) grid
    over ``labels`` (a cone or obstacle smaller than a cell keeps its cell; cones win over
    walls)."""
    starts = [np.floor(np.arange(n) * (total / n)).astype(np.int64) for n, total in
              zip(size, labels.shape[::-1], strict=True)]  # fmt: skip
    pooled: np.ndarray = np.maximum.reduceat(
        np.maximum.reduceat(labels, starts[1], 0), starts[0], 1
    )
    return pooled


def _draw_cones(labels: np.ndarray, to_cells: np.ndarray, track: Track, per_unit: float) -> None:
    """The track's cones as discs of their class's base radius (tracks in metres), or one
    cell each (tracks of unknown scale), labelled by class."""
    ids = np.clip(track.cones[:, 2].astype(np.int64), 0, len(CLASSES))
    metres = track.metres_per_unit
    radii = CONE_RADII[ids] / metres * per_unit if metres else np.zeros(len(ids))  # [cells]
    for (x, y, _), class_id, radius in zip(track.cones.tolist(), ids, radii, strict=True):
        cx, cy = to_cells @ (x, y, 1.0)
        cv2.circle(labels, (round(cx), round(cy)), round(radius), WALL_CLASS + int(class_id), -1)


def _picture_labels(
    picture: np.ndarray, obstacles: list[RGB], cone_colors: tuple[RGB, ...]
) -> np.ndarray:
    """(H, W) uint8 hit classes of a picture track's obstacle and cone colours."""
    labels = np.zeros(picture.shape[:2], np.uint8)
    for rgb in obstacles:
        labels[color_mask(picture, rgb)] = WALL_CLASS
    for class_id, rgb in enumerate(cone_colors, start=1):
        labels[color_mask(picture, rgb)] = WALL_CLASS + class_id
    return labels
