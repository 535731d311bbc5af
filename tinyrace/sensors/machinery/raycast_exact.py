"""The exact traversal (ROS maps): beams cross the map's cells as squares and stop where
they enter the first blocking one; the field of leaps that lets them skip free space.

The casts are ``raycast_numpy.cast_exact`` and ``kernels/raycast.py``'s compiled twin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from tinyrace.sensors.machinery.raycast import PAD, distance_map

# Exact traversal (ROS maps): beams cross the map's cells as squares, edges on half-integer
# cell coordinates, and stop where they enter the first blocking one
LEAP_MARGIN = 0.01  # [cells] a leap stops this far short of any blocking cell's square
LEAP_MIN = 1.0  # [cells] shorter leaps are not taken: the traversal steps cell by cell
LEAP_UNIT = 64  # leaps are stored in 1 / LEAP_UNIT cells (uint16), rounded down
EXACT_BLOCKED = 0xFFFF  # the value of a blocking cell in an exact field's ``cells``


@dataclass(frozen=True, eq=False)
class ExactField:
    """The blocking cells of a map for the exact traversal (``raycast_numpy.cast_exact``,
    ``kernels.raycast.cast_exact``), padded by PAD blocking cells (the map's edge stops a
    beam).

    ``cells`` (uint16) is EXACT_BLOCKED in blocking cells; in free ones, how far [1 /
    LEAP_UNIT cells] a beam may go from any point of the cell without entering a blocking
    cell's square (its centre's distance to the nearest blocking centre less sqrt(2), less
    LEAP_MARGIN), 0 where that is under LEAP_MIN: the traversal leaps there instead of
    stepping cell by cell. Leaps change no range: a leap ends in a free cell, and the
    cell-by-cell steps go on from there. One array, so that a step looks up one cell.
    """

    cells: np.ndarray  # (H, w) uint16
    to_cells: np.ndarray  # 2x3 affine: track units -> cell coordinates of the padded map
    cells_per_unit: float  # [cells per track unit]
    classes: np.ndarray | None = None  # (H, w) uint8 hit class of blocking cells and their rim

    @property
    def shape(self) -> tuple[int, int]:
        height, width = self.cells.shape
        return height, width

    def blocking(self) -> np.ndarray:
        """(H, w) uint8 map of the padded field, 1 where blocking."""
        blocking: np.ndarray = (self.cells == EXACT_BLOCKED).astype(np.uint8)
        return blocking

    def cell(self, point: tuple[float, float]) -> tuple[float, float]:
        """[cells] of a track point in the padded map."""
        (a, b, c), (d, e, f) = self.to_cells.tolist()
        return a * point[0] + b * point[1] + c, d * point[0] + e * point[1] + f


def exact_field(
    blocking: np.ndarray, to_cells: np.ndarray, classes: np.ndarray | None = None
) -> ExactField:
    """The exact field of a boolean (H, W) map of blocking cells (``to_cells``: the track ->
    cell affine, cell centres on integer coordinates); ``classes`` (H, W) uint8 hit classes
    of the blocking cells, when beams report them. The cell frame must be square (a
    rotation, a mirror and one scale)."""
    padded = cv2.copyMakeBorder(
        blocking.astype(np.uint8), PAD, PAD, PAD, PAD, cv2.BORDER_CONSTANT, value=1
    )
    leaps = distance_map(padded).astype(np.float64) - (math.sqrt(2) + LEAP_MARGIN)  # [cells]
    leaps[leaps < LEAP_MIN] = 0.0
    cells = np.floor(np.minimum(leaps * LEAP_UNIT, EXACT_BLOCKED - 1)).astype(np.uint16)
    cells[padded > 0] = EXACT_BLOCKED
    shifted = np.asarray(to_cells, np.float64) + np.array([[0, 0, PAD], [0, 0, PAD]])
    scale = math.sqrt(abs(np.linalg.det(shifted[:, :2])))
    if classes is not None:  # an end on a cell's edge may round to the free side: the rim too
        classes = cv2.copyMakeBorder(classes, PAD, PAD, PAD, PAD, cv2.BORDER_CONSTANT, value=1)
        classes = np.where(classes > 0, classes, cv2.dilate(classes, np.ones((3, 3), np.uint8)))
    return ExactField(cells, shifted, scale, classes)


def exact_fan(field: ExactField, angles: np.ndarray, y_down: bool) -> tuple[np.ndarray, ...]:
    """(cos, sin) float64 of each beam's angle in the cell frame for a car at heading 0 (beams
    at ``angles`` [rad, + left] of a car on a y-up track, or a y-down one)."""
    (a, b, _), (d, e, _) = field.to_cells.tolist()
    mirror = -1.0 if a * e < b * d else 1.0
    cell_angles = mirror * (-1.0 if y_down else 1.0) * np.asarray(angles, np.float64)
    return np.cos(cell_angles), np.sin(cell_angles)


def exact_turn(field: ExactField, heading: float) -> tuple[float, float]:
    """(cos, sin) of the angle that turns ``exact_fan``'s beams to a car at ``heading``
    [rad] (counter-clockwise on y-up tracks, clockwise on y-down ones) in the cell frame."""
    (a, b, _), (d, e, _) = field.to_cells.tolist()
    mirror = -1.0 if a * e < b * d else 1.0
    turn = math.atan2(d, a) + mirror * heading
    return math.cos(turn), math.sin(turn)
