"""The pymunk space: the car's body, the track's sensors and the contact facts they produce.

Collision callbacks only record facts (which tile a wheel touches, which obstacle
cell the footprint overlaps); rewards are decided elsewhere from those facts.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pymunk

from tinyrace.cars.collision import (
    CONE,
    FOOTPRINT,
    OBSTACLE,
    OBSTACLE_FILTER,
    TILE,
    WALL,
    WHEEL,
)
from tinyrace.world.tile_sensors import tile_sensors


@dataclass
class Contacts:
    """What the sensors reported; ``new_tile_touches`` is refilled every step."""

    wheel_tiles: list[set[int]] = field(default_factory=lambda: [set() for _ in range(4)])
    new_tile_touches: list[int] = field(default_factory=list)  # tiles a wheel began touching
    obstacle_cells: set[int] = field(default_factory=set)  # cells the footprint overlaps now
    walls: set[int] = field(default_factory=set)  # wall boxes the footprint overlaps now
    cones: set[int] = field(default_factory=set)  # cones the footprint overlaps now


class World:
    """A pymunk space holding static track sensors and one car.

    Units are the track's: world units on procedural tracks, pixels on image tracks.
    """

    def __init__(self) -> None:
        self.space = pymunk.Space()
        self.contacts = Contacts()
        self.space.on_collision(WHEEL, TILE, begin=self._wheel_on, separate=self._wheel_off)
        self.space.on_collision(FOOTPRINT, OBSTACLE, begin=self._cell_on, separate=self._cell_off)
        self.space.on_collision(FOOTPRINT, WALL, begin=self._wall_on, separate=self._wall_off)
        self.space.on_collision(FOOTPRINT, CONE, begin=self._cone_on, separate=self._cone_off)

    # -- track sensors ---------------------------------------------------------------------
    def add_tiles(self, tiles: np.ndarray) -> None:
        """Road tiles (N x 4 x 2 quads) as static sensors; a wheel on none of them is on grass."""
        self.space.add(*tile_sensors(self.space.static_body, tiles))

    def add_obstacle_cells(self, boxes: np.ndarray) -> None:
        """Axis-aligned boxes (M x 4: x0, y0, x1, y1) around obstacle pixels, as static sensors."""
        shapes = []
        for index, (x0, y0, x1, y1) in enumerate(boxes.tolist()):
            corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
            shapes.append(self._static_sensor(corners, OBSTACLE, index, OBSTACLE_FILTER))
        if shapes:
            self.space.add(*shapes)

    def add_walls(self, boxes: np.ndarray) -> None:
        """Solid cells of a map (M x 4: x0, y0, x1, y1); the footprint reports touching them."""
        shapes = []
        for index, (x0, y0, x1, y1) in enumerate(boxes.tolist()):
            corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
            shapes.append(self._static_sensor(corners, WALL, index, OBSTACLE_FILTER))
        if shapes:
            self.space.add(*shapes)

    def add_cones(self, positions: np.ndarray, radii: np.ndarray) -> None:
        """Cones (K x 2 centres, K radii) as static circles the footprint reports touching."""
        shapes = []
        for index, ((x, y), radius) in enumerate(
            zip(positions.tolist(), radii.tolist(), strict=True)
        ):
            shape = pymunk.Circle(self.space.static_body, radius, (x, y))
            shape.sensor = True
            shape.filter = OBSTACLE_FILTER
            shape.collision_type = CONE
            shape.index = index
            shapes.append(shape)
        if shapes:
            self.space.add(*shapes)

    def _static_sensor(
        self,
        vertices: list[tuple[float, float]],
        kind: int,
        index: int,
        shape_filter: pymunk.ShapeFilter,
    ) -> pymunk.Poly:
        shape = pymunk.Poly(self.space.static_body, vertices)
        shape.sensor = True
        shape.filter = shape_filter
        shape.collision_type = kind
        shape.index = index
        return shape

    def remove_cars(self) -> None:
        """Take every body but the static track out, so that a track's sensors serve many resets."""
        for body in list(self.space.bodies):
            self.space.remove(body, *body.shapes)
        self.contacts = Contacts()

    # -- pickling ----------------------------------------------------------------------------
    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._rebind_contacts()

    def _rebind_contacts(self) -> None:
        """Reconnect an unpickled space's touching pairs to the collision callbacks.

        pymunk restores the pairs that were touching but not which handler each belongs
        to, so their ``separate`` would never be reported. One collision pass with every
        body held still (a 1 ns step at zero velocity keeps positions bit-identical)
        rebinds them; every pair already touches, so no ``begin`` fires.
        """
        saved = [(body, body.velocity, body.angular_velocity) for body in self.space.bodies]
        for body, _, _ in saved:
            body.velocity, body.angular_velocity = (0.0, 0.0), 0.0
        self.space.step(1e-9)
        for body, velocity, spin in saved:
            body.velocity, body.angular_velocity = velocity, spin

    # -- stepping ----------------------------------------------------------------------------
    def step(self, dt: float) -> Contacts:
        """Advance the space by ``dt`` seconds; return the contact facts of this step."""
        self.contacts.new_tile_touches.clear()
        self.space.step(dt)
        return self.contacts

    @property
    def counts(self) -> tuple[int, int, int]:
        """(bodies, shapes, constraints) in the space, for leak checks."""
        return len(self.space.bodies), len(self.space.shapes), len(self.space.constraints)

    # -- callbacks: facts only ---------------------------------------------------------------
    # (pymunk may hand the pair over in either order when a space is torn down)
    def _wheel_on(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        wheel, tile = _ordered(arbiter, WHEEL)
        self.contacts.wheel_tiles[wheel.index].add(tile.index)
        self.contacts.new_tile_touches.append(tile.index)

    def _wheel_off(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        wheel, tile = _ordered(arbiter, WHEEL)
        self.contacts.wheel_tiles[wheel.index].discard(tile.index)

    def _cell_on(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        self.contacts.obstacle_cells.add(_ordered(arbiter, FOOTPRINT)[1].index)

    def _cell_off(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        self.contacts.obstacle_cells.discard(_ordered(arbiter, FOOTPRINT)[1].index)

    def _wall_on(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        self.contacts.walls.add(_ordered(arbiter, FOOTPRINT)[1].index)

    def _wall_off(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        self.contacts.walls.discard(_ordered(arbiter, FOOTPRINT)[1].index)

    def _cone_on(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        self.contacts.cones.add(_ordered(arbiter, FOOTPRINT)[1].index)

    def _cone_off(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        self.contacts.cones.discard(_ordered(arbiter, FOOTPRINT)[1].index)


def _ordered(arbiter: pymunk.Arbiter, first_type: int) -> tuple[pymunk.Shape, pymunk.Shape]:
    a, b = arbiter.shapes
    return (a, b) if a.collision_type == first_type else (b, a)
