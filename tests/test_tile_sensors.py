"""Tile sensors are the shapes a plain pymunk.Poly would be, and report wheels the same way."""

from __future__ import annotations

import pickle
from types import SimpleNamespace

import numpy as np
import pymunk

from tinyrace.cars.collision import TILE, TILE_FILTER, WHEEL, WHEEL_FILTER, footprint_sensor
from tinyrace.tracks.procedural import generate_track
from tinyrace.world.tile_sensors import tile_sensors
from tinyrace.world.world import World


def test_tile_sensors_match_plain_polys_built_one_attribute_at_a_time() -> None:
    tiles = generate_track(np.random.default_rng(7)).tiles
    space = pymunk.Space()
    shapes = tile_sensors(space.static_body, tiles)
    assert len(shapes) == len(tiles)
    for index, (shape, quad) in enumerate(zip(shapes, tiles, strict=True)):
        plain = pymunk.Poly(space.static_body, quad.tolist())
        assert isinstance(shape, pymunk.Poly)
        assert shape.get_vertices() == plain.get_vertices()  # same hull, same vertex order
        assert (shape.sensor, shape.collision_type, shape.index) == (True, TILE, index)
        assert shape.filter == TILE_FILTER
        assert shape.body is space.static_body


def _wheel_at(world: World, position: tuple[float, float]) -> pymunk.Body:
    """A body with one wheel (and the footprint every car has), taken in as car 0."""
    body = pymunk.Body(1.0, 1.0)
    body.position = position
    wheel = pymunk.Poly.create_box(body, (0.5, 0.5))
    wheel.sensor, wheel.collision_type, wheel.filter = True, WHEEL, WHEEL_FILTER
    wheel.index = 0
    world.space.add(body, wheel, footprint_sensor(body, (-0.25, -0.25), (0.25, 0.25)))
    world.add_car(SimpleNamespace(body=body))  # the world reads only the body of a car
    return body


def test_a_wheel_on_a_tile_is_reported_before_and_after_a_pickle_round_trip() -> None:
    track = generate_track(np.random.default_rng(3))
    world = World()
    world.add_tiles(track.tiles)
    target = 5
    _wheel_at(world, tuple(track.tiles[target].mean(axis=0)))
    [contacts] = world.look(0.02)  # a bare body: the space alone steps
    assert target in contacts.wheel_tiles[0]
    assert target in contacts.new_tile_touches
    clone = pickle.loads(pickle.dumps(world))
    assert clone.counts == world.counts
    [body] = list(clone.space.bodies)
    body.position = (1e4, 1e4)  # far off the track: the wheel leaves the tile
    clone.look(0.02)
    assert clone.contacts[0].wheel_tiles[0] == set()
    assert target in world.contacts[0].wheel_tiles[0]  # the original is untouched
