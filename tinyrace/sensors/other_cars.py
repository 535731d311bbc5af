"""Beams against the other cars: each car's footprint as an oriented box.

A lidar riding on one car of a race sees the others: ``ranges_to_cars`` gives, per beam,
the distance to the nearest other car's footprint (the rear-to-front-axle box, its width
wide), by the slab test in each box's own frame. numpy over the beams, one pass per car.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tinyrace.cars.state import CarState


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
    ox, oy = origin
    for car in cars:
        length, width = car.footprint
        heading = car.pose[2]
        ax = np.array([np.cos(heading), np.sin(heading)])  # the box's own axes
        ay = np.array([-ax[1], ax[0]])
        rx, ry = car.rear_axle
        centre = np.array([rx, ry]) + ax * length / 2
        offset = np.array([ox, oy]) - centre
        start = np.array([offset @ ax, offset @ ay])  # the origin in the box's frame
        half = np.array([length / 2, width / 2])
        direction = np.stack([beams @ ax, beams @ ay], axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            low = (-half - start) / direction
            high = (half - start) / direction
        near = np.fmax.reduce(np.minimum(low, high), axis=1)  # entry (NaN: parallel, ignored)
        far = np.fmin.reduce(np.maximum(low, high), axis=1)  # exit
        parallel_outside = (direction == 0) & (np.abs(start) > half)
        hit = (far >= np.maximum(near, 0.0)) & ~parallel_outside.any(axis=1)
        distance = np.where(hit, np.maximum(near, 0.0), np.inf)
        nearest = np.minimum(nearest, distance)
    return nearest.astype(np.float32)
