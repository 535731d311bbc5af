"""Collision categories shared by the cars' shapes and the world's static track shapes.

pymunk pairs shapes by these filters; the world's callbacks are keyed by the types.
"""

from __future__ import annotations

import pymunk

# Collision types: what a sensor shape stands for.
WHEEL = 1
TILE = 2
FOOTPRINT = 3
OBSTACLE = 4
WALL = 5  # solid map cells: the car stops against them
CONE = 6  # a cone: knocked over when the footprint touches it
CAR = 7  # a car's solid outline: cars push each other apart

# Filters keep pymunk from pairing shapes that have nothing to report (wheel-obstacle, ...).
_WHEEL_BIT, _TILE_BIT, _FOOTPRINT_BIT, _OBSTACLE_BIT, _CAR_BIT = 1, 2, 4, 8, 16
NOTHING = pymunk.ShapeFilter(categories=0, mask=0)  # shapes that only carry mass
WHEEL_FILTER = pymunk.ShapeFilter(categories=_WHEEL_BIT, mask=_TILE_BIT)
TILE_FILTER = pymunk.ShapeFilter(categories=_TILE_BIT, mask=_WHEEL_BIT)
FOOTPRINT_FILTER = pymunk.ShapeFilter(categories=_FOOTPRINT_BIT, mask=_OBSTACLE_BIT)
OBSTACLE_FILTER = pymunk.ShapeFilter(categories=_OBSTACLE_BIT, mask=_FOOTPRINT_BIT)
CAR_FILTER = pymunk.ShapeFilter(categories=_CAR_BIT, mask=_CAR_BIT)  # cars meet cars only


def footprint_sensor(
    body: pymunk.Body, low: tuple[float, float], high: tuple[float, float]
) -> pymunk.Poly:
    """The car's obstacle footprint: a box from ``low`` to ``high`` in the body's frame."""
    (x0, y0), (x1, y1) = low, high
    shape = pymunk.Poly(body, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
    shape.sensor = True
    shape.collision_type = FOOTPRINT
    shape.filter = FOOTPRINT_FILTER
    return shape
