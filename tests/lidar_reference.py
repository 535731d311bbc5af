"""The reference of the exact lidar: an Amanatides-Woo grid traversal of a ROS map's occupied
pixels, written from the map's YAML numbers alone (not from tinyrace's affine), one beam at
a time in plain Python. Used by tests/test_lidar_exact.py and benchmarks/lidar_f1tenth.py."""

from __future__ import annotations

import math

import numpy as np


def trace(
    occupied: np.ndarray,
    resolution: float,
    origin: tuple[float, float, float],
    start: tuple[float, float],
    angle: float,
    max_range: float,
) -> float:
    """[m] from ``start`` [m] along world ``angle`` [rad] to the first occupied pixel of
    ``occupied`` (H, W) bool (image row 0 at the top; ``origin`` the pose of the lower-left
    pixel's corner [m, m, rad]), at most ``max_range``; the map's edge stops a beam; 0 from
    an occupied pixel or off the map."""
    height, width = occupied.shape
    ox, oy, yaw = origin
    c, s = math.cos(yaw), math.sin(yaw)
    # the map's frame: x along the picture's columns, y up its rows, in pixels
    px = (c * (start[0] - ox) + s * (start[1] - oy)) / resolution
    py = (-s * (start[0] - ox) + c * (start[1] - oy)) / resolution
    dx, dy = math.cos(angle - yaw), math.sin(angle - yaw)
    i, j = math.floor(px), math.floor(py)  # column, row counted from the bottom

    def blocked(i: int, j: int) -> bool:
        return not (0 <= i < width and 0 <= j < height) or bool(occupied[height - 1 - j, i])

    if blocked(i, j):
        return 0.0
    step_i, step_j = (1 if dx > 0 else -1), (1 if dy > 0 else -1)
    next_i = ((i + (dx > 0)) - px) / dx if dx != 0 else math.inf  # [px] to the next column
    next_j = ((j + (dy > 0)) - py) / dy if dy != 0 else math.inf
    delta_i = abs(1 / dx) if dx != 0 else math.inf
    delta_j = abs(1 / dy) if dy != 0 else math.inf
    limit = max_range / resolution
    while True:
        if next_i < next_j:
            t, i, next_i = next_i, i + step_i, next_i + delta_i
        else:
            t, j, next_j = next_j, j + step_j, next_j + delta_j
        if t >= limit:
            return max_range
        if blocked(i, j):
            return t * resolution


def scan(
    occupied: np.ndarray,
    resolution: float,
    origin: tuple[float, float, float],
    start: tuple[float, float],
    angles: np.ndarray,
    max_range: float,
) -> np.ndarray:
    """[m] ``trace`` of each world angle [rad]."""
    return np.array(
        [trace(occupied, resolution, origin, start, float(a), max_range) for a in angles]
    )
