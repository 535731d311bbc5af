"""Beams against the other cars: each car's footprint as an oriented box.

A lidar riding on one car of a race sees the others: ``ranges_to_cars`` gives, per beam,
the distance to the nearest other car's footprint (the rear-to-front-axle box, its width
wide), by the slab test in each box's own frame. numpy over the beams, one pass per car.

``add_cars`` is the lidar's call: it lowers a scan's ranges to the other cars' distances,
its beams given by their fixed angles (``fan``) turned by the car's heading. This is the
plain path; ``tinyrace.sensors.kernels.other_cars`` is its compiled twin (the lidar's
``kernel``), with the same float64 arithmetic in the same order (``box``, the beams' turn
and the slab test written out alike; tests/test_other_cars_kernel.py), which tests only
the beams within the angle a box spans as seen from the origin (a few of a 1080-beam fan)
and gives the same ranges bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from tinyrace.cars.state import CarState

CAR_FIELDS = 5  # per car: rear axle x, y [track units], heading [rad], length, width


def ranges_to_cars(
    origin: tuple[float, float],
    beams: np.ndarray,
    cars: Sequence[CarState],
    max_range: float,
) -> np.ndarray:
    """(B,) float32 distances [track units] from ``origin`` along ``beams`` ((B, 2) unit
    vectors) to the nearest footprint of ``cars``; ``max_range`` where a beam meets none,
    0 from inside a footprint."""
    nearest = np.full(len(beams), max_range, np.float64)
    bx, by = beams[:, 0], beams[:, 1]
    for row in car_rows(cars):
        nearest = np.minimum(nearest, _distances(origin, bx, by, row))
    return nearest.astype(np.float32)


def car_rows(cars: Sequence[CarState]) -> np.ndarray:
    """(K, CAR_FIELDS) float64: each car's rear axle x, y, heading, length and width."""
    rows = [(*car.rear_axle, car.pose[2], *car.footprint) for car in cars]
    return np.array(rows, np.float64).reshape(len(rows), CAR_FIELDS)


class BeamFan(NamedTuple):
    """A lidar's beams (``fan``): the cosines and sines of their angles [rad, + left of the
    car], and the angles' first, step and whether they go round the full circle (for the
    compiled path's choice of beams)."""

    cos: np.ndarray
    sin: np.ndarray
    first: float  # [rad]
    step: float  # [rad]
    full: bool


def fan(angles: np.ndarray) -> BeamFan:
    """The beams at ``angles`` (evenly spaced, rightmost first), once per lidar."""
    count = len(angles)
    step = float(angles[-1] - angles[0]) / (count - 1) if count > 1 else 1.0
    full = count > 1 and float(angles[-1] - angles[0]) + step >= 2 * math.pi - 1e-9
    return BeamFan(np.cos(angles), np.sin(angles), float(angles[0]), step, full)


def turned(
    cos_a: np.ndarray, sin_a: np.ndarray, c: float, s: float, y_down: bool
) -> tuple[np.ndarray, np.ndarray]:
    """The beams' (x, y) unit vectors [track units] for a car whose heading has cosine ``c``
    and sine ``s`` (beams at heading + angle; heading - angle on y-down tracks)."""
    if y_down:
        return c * cos_a + s * sin_a, s * cos_a - c * sin_a
    return c * cos_a - s * sin_a, s * cos_a + c * sin_a


def box(
    ox: float, oy: float, rx: float, ry: float, heading: float, length: float, width: float
) -> tuple[float, float, float, float, float, float]:
    """A footprint seen from the origin (ox, oy): the origin in the box's frame (ahead,
    left of its centre), the box's axis (cos, sin) and its half length and width."""
    ax, ay = math.cos(heading), math.sin(heading)
    cx, cy = rx + ax * length / 2, ry + ay * length / 2  # the box's centre
    dx, dy = ox - cx, oy - cy
    return dx * ax + dy * ay, dx * -ay + dy * ax, ax, ay, length / 2, width / 2


def add_cars(
    ranges: np.ndarray,
    origin: tuple[float, float],
    heading: float,
    y_down: bool,
    beam_fan: BeamFan,
    rows: np.ndarray,
    max_range: float,
) -> np.ndarray:
    """float32 ``ranges`` [track units] of the beams of ``beam_fan`` (``fan``) from
    ``origin``, lowered to the distance to the nearest car of ``rows`` (``car_rows``) a
    beam meets (a new array)."""
    bx, by = turned(beam_fan.cos, beam_fan.sin, math.cos(heading), math.sin(heading), y_down)
    nearest = np.full(len(bx), max_range, np.float64)
    for row in rows:
        nearest = np.minimum(nearest, _distances(origin, bx, by, row))
    lowered: np.ndarray = np.minimum(ranges, nearest.astype(np.float32))
    return lowered


def _distances(
    origin: tuple[float, float], bx: np.ndarray, by: np.ndarray, row: np.ndarray
) -> np.ndarray:
    """(B,) float64 distance along each beam to one car's footprint; inf where it misses."""
    sx, sy, ax, ay, half_length, half_width = box(*origin, *row.tolist())
    dx, dy = bx * ax + by * ay, bx * -ay + by * ax  # the beams in the box's frame
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # inf: parallel
        near_x, far_x = _slab(sx, dx, half_length)
        near_y, far_y = _slab(sy, dy, half_width)
    near = np.fmax(near_x, near_y)  # entry (NaN: parallel on the slab's edge, ignored)
    far = np.fmin(far_x, far_y)  # exit
    outside = ((dx == 0) & (abs(sx) > half_length)) | ((dy == 0) & (abs(sy) > half_width))
    entry = np.maximum(near, 0.0)
    return np.where((far >= entry) & ~outside, entry, np.inf)


def _slab(start: float, direction: np.ndarray, half: float) -> tuple[np.ndarray, np.ndarray]:
    """Where the beams enter and leave the slab |x| <= half of one axis (from ``start``)."""
    low, high = (-half - start) / direction, (half - start) / direction
    return np.minimum(low, high), np.maximum(low, high)
