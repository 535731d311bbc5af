"""The road tiles of a track as pymunk sensor shapes, built with as little Python as pymunk allows.

A CarRacing track has about 300 tiles and a new track every reset, so building their shapes
is a large part of a reset. Each shape costs a handful of attribute writes inside pymunk
and here; pymunk routes every one of them through a Python-level ``__setattr__`` that only
exists to please type checkers. Tile sensors skip that detour; nothing else changes (the
same vertices, the same convex hull, the same filter, type and index).
"""

from __future__ import annotations

import numpy as np
import pymunk

from tinyrace.cars.collision import TILE, TILE_FILTER

_IDENTITY = pymunk.Transform.identity()  # vertices are given in the static body's frame


class TileSensor(pymunk.Poly):
    """A pymunk polygon whose attribute writes go straight to the instance (no Python hop)."""

    index: int  # the tile's index in the track

    # properties (sensor, filter, ...) still run their setters; the base's annotation differs
    __setattr__ = object.__setattr__  # type: ignore[assignment]


def tile_sensors(body: pymunk.Body, tiles: np.ndarray) -> list[pymunk.Poly]:
    """One sensor per quad of ``tiles`` (N x 4 x 2), shape ``index`` = the tile's index."""
    shapes: list[pymunk.Poly] = []
    # One quad's vertex lists at a time: they die at once, instead of ~1300 lists that would
    # outlive the loop, wake the garbage collector and be promoted to its older generations.
    for index, quad in enumerate(tiles):
        shape = TileSensor(body, quad.tolist(), _IDENTITY)
        shape.sensor = True
        shape.filter = TILE_FILTER
        shape.collision_type = TILE
        shape.index = index
        shapes.append(shape)
    return shapes
