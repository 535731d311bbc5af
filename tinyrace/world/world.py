"""The pymunk space: the track's static shapes, the cars, and the contact facts they produce.

``World.step`` hands each car its controls, gives each wheel the grip of the ground its
own contacts report, steps the space and applies the physical consequences (a wall stops
a car, and so does another car); it returns every car's contacts as the step's
physical facts. ``snapshot`` copies the cars' states for the layers above. Collision
callbacks only record facts (which tile a wheel of which car touches, which obstacle
cell, wall, cone or other car a car's outline meets); rules and rewards are decided
elsewhere from those facts.

The stepping protocol (what an env and a batch of envs call, nothing else):
``control(controls, car)`` per car, then ``step(dt)``, which is ``apply_forces(dt)``
(each car's forces from its controls and its wheels' grip, ``wheel_grip(car)``)
followed by ``advance(dt)`` (the space stepped, crashes undone). A batch that computes
many worlds' forces at once (``tinyrace.vector.batched``) sets them on the cars and
calls ``advance`` alone.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pymunk
from pymunk._chipmunk_cffi import lib as _chipmunk  # pymunk 7's C functions (see _depth)

from tinyrace.cars.base import Car
from tinyrace.cars.collision import (
    CAR,
    CAR_FILTER,
    CONE,
    FOOTPRINT,
    OBSTACLE,
    OBSTACLE_FILTER,
    TILE,
    WALL,
    WHEEL,
)
from tinyrace.cars.state import CarState
from tinyrace.tracks.base import as_quads
from tinyrace.world.snapshot import Snapshot
from tinyrace.world.tile_sensors import tile_sensors

MAX_CARS = 16  # cars one world holds
TOUCH = 1e-6  # [track units] an overlap this deep or less is a touch, not a hit (rounding)


@dataclass
class Contacts:
    """What one car's sensors reported; ``new_tile_touches`` and ``new_cars`` are refilled
    every step."""

    wheel_tiles: list[set[int]] = field(default_factory=lambda: [set() for _ in range(4)])
    new_tile_touches: list[int] = field(default_factory=list)  # tiles a wheel began touching
    obstacle_cells: set[int] = field(default_factory=set)  # cells the footprint overlaps now
    walls: set[int] = field(default_factory=set)  # walls the footprint runs into now
    cones: set[int] = field(default_factory=set)  # cones the footprint overlaps now
    cars: set[int] = field(default_factory=set)  # other cars (world indices) it overlaps now
    new_cars: list[int] = field(default_factory=list)  # cars it began overlapping this step
    crashed: bool = False  # this step ran into a wall: the car was put back and stopped
    # (running into another car puts it back and stops it too, unless it was moving straight
    # away from every car it touches: ``cars``/``new_cars`` say whom it touched)


class World:
    """A pymunk space holding static track sensors and up to ``MAX_CARS`` cars.

    Units are the track's: world units on procedural tracks, pixels on image tracks,
    metres on metric tracks. ``grass_off_tiles``: a wheel touching no road tile grips as
    on grass (CarRacing); otherwise every wheel grips as on road. ``touch`` [track units]:
    a car whose outline overlaps a wall, a cone or another car by no more than this only
    touches it (not a hit: it drives on, and the contact is not reported). Cars are numbered in
    the order they were added; ``contacts[i]`` and ``states()[i]`` are car ``i``'s.
    """

    def __init__(self, grass_off_tiles: bool = False, touch: float = TOUCH) -> None:
        self.space = pymunk.Space()
        self.grass_off_tiles = grass_off_tiles
        self.touch = touch
        self.cars: list[Car] = []
        self.contacts: list[Contacts] = []  # per car
        self.parked: set[int] = set()  # cars out of the race: they stand still where they are
        self.gone: set[int] = set()  # parked cars taken off the track: nothing meets them
        self._states: tuple[CarState, ...] | None = None  # the cars' states since the last step
        self._walls = False
        self.space.on_collision(WHEEL, TILE, begin=self._wheel_on, separate=self._wheel_off)
        self.space.on_collision(FOOTPRINT, OBSTACLE, begin=self._cell_on, separate=self._cell_off)
        # walls, cones and cars: judged on every step's overlap (pre_solve): a touch is no hit
        self.space.on_collision(FOOTPRINT, WALL, pre_solve=self._wall_on, separate=self._wall_off)
        self.space.on_collision(FOOTPRINT, CONE, pre_solve=self._cone_on, separate=self._cone_off)
        self.space.on_collision(CAR, CAR, pre_solve=self._car_on, separate=self._car_off)

    # -- cars ----------------------------------------------------------------------------------
    def add_car(self, car: Car) -> int:
        """Take ``car`` (already built into ``self.space``) into the world; returns its index.

        The world gives it an outline (its footprint's box) that meets other cars' outlines,
        and tags its shapes with its index for the contacts."""
        index = len(self.cars)
        if index >= MAX_CARS:
            raise ValueError(f"a world holds at most {MAX_CARS} cars")
        for shape in car.body.shapes:
            shape.car = index
        self.space.add(_outline(car.body, index))
        self.cars.append(car)
        self.contacts.append(Contacts())
        self._states = None
        return index

    def control(self, controls: Sequence[Any], car: int = 0) -> None:
        """Hand the controls of one action (e.g. steer, gas, brake) to car ``car``."""
        self.cars[car].control(*controls)

    def park(self, car: int) -> None:
        """Take car ``car`` out of the race: it stops now and stays where it is, an obstacle
        the other cars still meet (its contacts are still reported)."""
        self.parked.add(car)
        self.cars[car].stop()

    def retire(self, car: int) -> None:
        """Take car ``car`` off the track: parked, and its body out of the space, so that
        nothing meets it any more (a car that finished its race does not block the line)."""
        self.park(car)
        if car not in self.gone:
            self.gone.add(car)
            body = self.cars[car].body
            self.space.remove(body, *body.shapes)
            contacts = self.contacts[car]
            for other in contacts.cars:
                self.contacts[other].cars.discard(car)
            self.contacts[car] = Contacts()

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

    def add_walls(self, walls: np.ndarray) -> None:
        """Solid walls (M x 4 boxes x0, y0, x1, y1, or M x 4 x 2 convex quads: a map's
        pixels); the footprint reports running into them."""
        shapes = []
        for index, corners in enumerate(as_quads(walls).tolist()):
            shapes.append(self._static_sensor(corners, WALL, index, OBSTACLE_FILTER))
        if shapes:
            self.space.add(*shapes)
            self._walls = True

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
        self.contacts = []
        self.cars = []
        self.parked = set()
        self.gone = set()
        self._states = None

    # -- pickling ----------------------------------------------------------------------------
    def __getstate__(self) -> dict[str, object]:
        return {**self.__dict__, "_states": None}  # skid views would unpickle detached

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

    def footprints(self) -> list[np.ndarray]:
        """Per car, the (4, 2) corners [track units] of the outline that meets walls, cones
        and other cars, where its body stands now (its whole body on the single-track car,
        not only from axle to axle)."""
        quads = []
        for car in self.cars:
            body = car.body
            shape = next(s for s in body.shapes if s.collision_type == FOOTPRINT)
            quads.append(np.array([tuple(body.local_to_world(v)) for v in shape.get_vertices()]))
        return quads

    # -- stepping ----------------------------------------------------------------------------
    def step(self, dt: float, actions: Sequence[Sequence[Any]] = ()) -> list[Contacts]:
        """One step of ``dt`` seconds: ``actions`` (controls per car, if given) handed over,
        every car's forces with each wheel's grip from its contacts, the space stepped, a
        car that ran into a wall put back and stopped. Returns every car's contact facts
        (the world's own objects, valid until the next step)."""
        for car, controls in zip(self.cars, actions, strict=False):
            car.control(*controls)
        self.apply_forces(dt)
        return self.advance(dt)

    def apply_forces(self, dt: float) -> None:
        """Every car's forces for a step of ``dt`` seconds, from its controls and its wheels'
        grip (the first half of ``step``)."""
        parked = self.parked
        for index, car in enumerate(self.cars):
            if index not in parked:
                car.apply_forces(dt, self.wheel_grip(index))

    def advance(self, dt: float) -> list[Contacts]:
        """The space stepped by ``dt`` seconds with the forces the cars hold; a car that ran
        into a wall or another car is put back where it stood and stopped (the second half
        of ``step``; a batch that set many worlds' forces at once calls this alone)."""
        cars = self.cars
        before = [_place(car.body) for car in cars] if self._walls or len(cars) > 1 else None
        self.look(dt)
        if before is not None:
            parked = self.parked
            for index, (car, contacts, place) in enumerate(
                zip(cars, self.contacts, before, strict=True)
            ):
                if contacts.walls or index in parked or _closing_in(car, place, contacts, before):
                    _crash(car, place)
                    contacts.crashed = bool(contacts.walls)
        return self.contacts

    def wheel_grip(self, car: int = 0) -> Sequence[bool]:
        """Per wheel of car ``car``: grips as on road (else as on grass), from its contacts."""
        if self.grass_off_tiles:
            return list(map(bool, self.contacts[car].wheel_tiles))
        return _ALL_ROAD

    def look(self, dt: float) -> list[Contacts]:
        """Step the space by ``dt`` seconds without driving (a reset's look at the spawn)."""
        for contacts in self.contacts:
            contacts.new_tile_touches.clear()
            contacts.new_cars.clear()
            contacts.crashed = False
        self._states = None
        self.space.step(dt)
        return self.contacts

    def states(self) -> tuple[CarState, ...]:
        """Every car's state, copied once per step (the controlled car first); a body
        changed by hand between steps shows in the next step's states."""
        if self._states is None:
            self._states = tuple(car.state() for car in self.cars)
        return self._states

    def snapshot(self, t: float, steps: int, score: float = 0.0) -> Snapshot:
        """The world now, labelled with the episode's clock (``t`` [s], ``steps``) and the
        controlled car's running reward (``score``)."""
        return Snapshot(t, steps, self.states(), gone=frozenset(self.gone), score=score)

    @property
    def counts(self) -> tuple[int, int, int]:
        """(bodies, shapes, constraints) in the space, for leak checks."""
        return len(self.space.bodies), len(self.space.shapes), len(self.space.constraints)

    # -- callbacks: facts only ---------------------------------------------------------------
    # (pymunk may hand the pair over in either order when a space is torn down)
    def _wheel_on(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        wheel, tile = _ordered(arbiter, WHEEL)
        contacts = self.contacts[wheel.car]
        contacts.wheel_tiles[wheel.index].add(tile.index)
        contacts.new_tile_touches.append(tile.index)

    def _wheel_off(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        wheel, tile = _ordered(arbiter, WHEEL)
        self.contacts[wheel.car].wheel_tiles[wheel.index].discard(tile.index)

    def _cell_on(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        car, cell = _ordered(arbiter, FOOTPRINT)
        self.contacts[car.car].obstacle_cells.add(cell.index)

    def _cell_off(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        car, cell = _ordered(arbiter, FOOTPRINT)
        self.contacts[car.car].obstacle_cells.discard(cell.index)

    def _wall_on(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        car, wall = _ordered(arbiter, FOOTPRINT)
        walls = self.contacts[car.car].walls
        if _depth(arbiter) > self.touch:
            walls.add(wall.index)
        else:
            walls.discard(wall.index)

    def _wall_off(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        car, wall = _ordered(arbiter, FOOTPRINT)
        self.contacts[car.car].walls.discard(wall.index)

    def _cone_on(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        car, cone = _ordered(arbiter, FOOTPRINT)
        cones = self.contacts[car.car].cones
        if _depth(arbiter) > self.touch:
            cones.add(cone.index)
        else:
            cones.discard(cone.index)

    def _cone_off(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        car, cone = _ordered(arbiter, FOOTPRINT)
        self.contacts[car.car].cones.discard(cone.index)

    def _car_on(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        a, b = arbiter.shapes
        deep = _depth(arbiter) > self.touch
        for me, other in ((a.car, b.car), (b.car, a.car)):
            contacts = self.contacts[me]
            if not deep:
                contacts.cars.discard(other)
            elif other not in contacts.cars:
                contacts.cars.add(other)
                contacts.new_cars.append(other)

    def _car_off(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        a, b = arbiter.shapes
        if a.car < len(self.contacts) and b.car < len(self.contacts):  # not a torn-down car
            self.contacts[a.car].cars.discard(b.car)
            self.contacts[b.car].cars.discard(a.car)


_ALL_ROAD = (True, True, True, True)  # per wheel: grips as on road
Place = tuple[tuple[float, float], float]  # a body's (position, angle)


def _place(body: pymunk.Body) -> Place:
    x, y = body.position
    return (float(x), float(y)), float(body.angle)


def _closing_in(car: Car, place: Place, contacts: Contacts, before: list[Place]) -> bool:
    """Whether a car touching other cars moved this step other than straight away from each
    of them (the one it ran into stays put back, the one it touched that was pulling away
    drives on: two cars touching nose to tail would otherwise stand there for good)."""
    if not contacts.cars:
        return False
    (x0, y0), _ = place
    x, y = car.body.position
    dx, dy = x - x0, y - y0
    for other in contacts.cars:
        (ox, oy), _ = before[other]
        if dx * (ox - x0) + dy * (oy - y0) >= 0.0:  # towards it, or across, or not at all
            return True
    return False


def _crash(car: Car, before: Place) -> None:
    """Against a wall: back to where the car stood before the step, at a standstill."""
    car.body.position, car.body.angle = before
    car.stop()


def _outline(body: pymunk.Body, index: int) -> pymunk.Poly:
    """A car's outline for meeting other cars: its footprint's box, a sensor that pairs with
    other cars' outlines only (a car model may drive its body by velocity, which pymunk's
    contact impulses would not slow: the world stops both cars instead, as at a wall)."""
    footprint = next(shape for shape in body.shapes if shape.collision_type == FOOTPRINT)
    outline = pymunk.Poly(body, footprint.get_vertices())
    outline.sensor = True
    outline.collision_type = CAR
    outline.filter = CAR_FILTER
    outline.car = index
    return outline


def _depth(arbiter: pymunk.Arbiter) -> float:
    """[track units] how deep two shapes overlap (0 when they only touch). Read from
    Chipmunk's own contact set: ``arbiter.contact_point_set`` builds Python vectors for
    every point, 4x the time, and this runs on every step a car meets a wall."""
    points = _chipmunk.cpArbiterGetContactPointSet(arbiter._arbiter)
    return -min((points.points[i].distance for i in range(points.count)), default=0.0)


def _ordered(arbiter: pymunk.Arbiter, first_type: int) -> tuple[pymunk.Shape, pymunk.Shape]:
    a, b = arbiter.shapes
    return (a, b) if a.collision_type == first_type else (b, a)
