"""CarRacing's rear-wheel-drive car on one pymunk body.

The hull and the four wheels share one rigid body (the wheels carry their own
mass, as in the reference); each wheel keeps its own spin, steering angle, gas
and brake. Tyre forces follow CarRacing-v3's model: a slip force proportional
to the difference between rim speed and ground speed, capped by the friction
limit of the surface under the wheel (road 1.0, grass 0.6).

The model is written in CarRacing's frame (y up, angles counter-clockwise). A
``scale`` (track units per world unit) and ``y_down`` put it on an image track.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any
from typing import cast as typed

import numpy as np
import pymunk
from pymunk._chipmunk_cffi import lib as _chipmunk

from tinyrace import kernels
from tinyrace.cars import dynamic_python
from tinyrace.cars.collision import NOTHING, WHEEL, WHEEL_FILTER, footprint_sensor
from tinyrace.cars.dynamic_layout import (
    BRAKE,
    CONSTANTS,
    GAS,
    OMEGA,
    PHASE,
    SKID,
    STEER,
    car_constants,
    new_state,
)
from tinyrace.cars.dynamic_shape import (
    HULL_POLYGONS,
    SIZE,
    WHEEL_HALF_WIDTH,
    WHEEL_POSITIONS,
    WHEEL_RADIUS,
    DynamicCarSpec,
)
from tinyrace.cars.state import CarState, Point, SkidView, WheelState, read_only


class _Column:
    """A float state of a wheel, kept in its row of the car's state array."""

    def __init__(self, row: int, doc: str) -> None:
        self.row, self.__doc__ = row, doc

    def __get__(self, wheel: Wheel, owner: type | None = None) -> float:
        return float(wheel._state[self.row, wheel._column])

    def __set__(self, wheel: Wheel, value: float) -> None:
        wheel._state[self.row, wheel._column] = value


class Wheel:
    """One wheel: its position in the body's frame (track units) and its state, a column
    of the car's state array (see ``dynamic_layout``), read and set as attributes."""

    __slots__ = ("_column", "_state", "x", "y")

    def __init__(self, x: float, y: float, state: np.ndarray, column: int) -> None:
        self.x, self.y = x, y
        self._state, self._column = state, column

    omega = _Column(OMEGA, "[rad/s] spin")
    steer = _Column(STEER, "[rad] steering angle (front wheels)")
    gas = _Column(GAS, "0..1 (rear wheels)")
    brake = _Column(BRAKE, "0..1")
    phase = _Column(PHASE, "[rad] accumulated spin, for drawing")

    @property
    def skidding(self) -> bool:
        """The tyre force passed the skid threshold in the last step."""
        return bool(self._state[SKID, self._column])

    @skidding.setter
    def skidding(self, value: bool) -> None:
        self._state[SKID, self._column] = float(value)

    def __repr__(self) -> str:
        fields = ("x", "y", "omega", "steer", "gas", "brake", "phase", "skidding")
        return f"Wheel({', '.join(f'{name}={getattr(self, name)!r}' for name in fields)})"


class SkidMarks:
    """The newest skid marks, polylines in track units, kept in one ring of arrays."""

    def __init__(self, capacity: int = 30, max_points: int = 30):
        self.points = np.zeros((capacity, max_points, 2))  # [track units]
        self.lengths = np.zeros(capacity, np.int64)  # points used per mark; 0 = free
        self.on_grass = np.zeros(capacity, bool)
        self.serial = np.zeros(capacity, np.int64)  # which mark a slot holds now
        self._next = 0
        self._count = 0
        self._view: SkidView | None = None

    def view(self) -> SkidView:
        """Read-only views of the ring (made once; a pickled copy makes its own)."""
        if self._view is None:
            self._view = SkidView(
                read_only(self.points), read_only(self.lengths), read_only(self.on_grass)
            )
        return self._view

    def __getstate__(self) -> dict[str, object]:
        return {**self.__dict__, "_view": None}  # views would unpickle as detached copies

    def start(self, first: Point, second: Point, on_grass: bool) -> tuple[int, int]:
        """A new two-point mark (evicting the oldest); returns its handle (slot, serial)."""
        slot = self._next
        self._next = (slot + 1) % len(self.lengths)
        self._count += 1
        self.points[slot, :2] = (first, second)
        self.lengths[slot] = 2
        self.on_grass[slot] = on_grass
        self.serial[slot] = self._count
        return slot, self._count

    def extend(self, handle: tuple[int, int], point: Point, on_grass: bool) -> bool:
        """Append to a mark if it still exists, is on the same ground and has room."""
        slot, serial = handle
        n = self.lengths[slot]
        if (
            self.serial[slot] != serial
            or self.on_grass[slot] != on_grass
            or n >= self.points.shape[1]
        ):
            return False
        self.points[slot, n] = point
        self.lengths[slot] = n + 1
        return True


# pymunk sends every attribute set through a Python ``__setattr__`` hook; the properties'
# setters called directly skip it (about 0.5 us each, twice per step)
_set_velocity = vars(pymunk.Body)["velocity"].fset
_set_angular_velocity = vars(pymunk.Body)["angular_velocity"].fset
# the hot path reads and sets the body by the chipmunk calls that pymunk's Body properties
# make (on its pointer ``body._body``), without their Python frames and Vec2d tuples: the
# same doubles (pymunk is pinned to 7.x)
_get_position, _get_velocity = _chipmunk.cpBodyGetPosition, _chipmunk.cpBodyGetVelocity
_get_angle, _get_spin = _chipmunk.cpBodyGetAngle, _chipmunk.cpBodyGetAngularVelocity
_put_velocity, _put_spin = _chipmunk.cpBodySetVelocity, _chipmunk.cpBodySetAngularVelocity

PHYSICS_VARIABLE = "TINYRACE_PHYSICS"  # environment variable: auto | numba | python
Forces = Callable[
    [np.ndarray, np.ndarray, float, float, float, float, float, float, int],
    tuple[float, float, float, int],
]


@dataclass
class DynamicCar:
    """The car: a pymunk body plus wheel states. Controls are set, then ``apply_forces(dt)``.

    The wheels' state is one array, ``wheel_state`` (see ``dynamic_layout``); each
    ``Wheel`` reads and sets its column. The tyre model runs compiled (numba) or in
    Python, with the same results (see ``physics_kernel``).
    """

    body: pymunk.Body
    wheels: list[Wheel]
    spec: DynamicCarSpec
    scale: float  # [track units per u]
    steer_sign: float  # +1 in CarRacing's y-up frame, -1 on a y-down image
    steer_action: float = -1.0  # [rad per action unit] steer_target of a steer action of 1
    steer_target: float = 0.0  # [rad] internal sign (positive: counter-clockwise)
    skids: SkidMarks = field(default_factory=SkidMarks)
    wheel_state: np.ndarray = field(default_factory=lambda: new_state(1))
    # per wheel: the mark being drawn (its handle), and a first point waiting for a second
    _skid_open: list[tuple[int, int] | None] = field(default_factory=lambda: [None] * 4)
    _skid_start: list[Point | None] = field(default_factory=lambda: [None] * 4)

    @classmethod
    def build(
        cls,
        space: pymunk.Space,
        pose: tuple[float, float, float],
        scale: float = 1.0,
        y_down: bool = False,
        spec: DynamicCarSpec = DynamicCarSpec(),
        steer_left: bool = False,
    ) -> DynamicCar:
        """Add a car at ``pose`` (x, y, heading: the forward direction's angle from +x); a
        positive steer action turns it right (CarRacing's), or left with ``steer_left``."""
        body = pymunk.Body()
        x, y, heading = pose
        body.position = (x, y)
        body.angle = heading - math.pi / 2  # the model's nose points along its +y axis
        unit = SIZE * scale  # [track units per model unit]
        shapes = [
            _hull_shape(body, poly, unit, spec.hull_density / scale**2) for poly in HULL_POLYGONS
        ]
        state = new_state(1)
        wheels = []
        for index, (wx, wy) in enumerate(WHEEL_POSITIONS):
            wheels.append(Wheel(wx * unit, wy * unit, state, index))
            shapes.append(_wheel_sensor(body, index, wx, wy, unit, spec.wheel_density / scale**2))
        rear, base, width = _footprint(scale)
        shapes.append(footprint_sensor(body, (-width / 2, rear), (width / 2, rear + base)))
        space.add(body, *shapes)
        sign = -1.0 if y_down else 1.0
        action = sign if steer_left else -sign  # a right turn: clockwise on screen
        return cls(body, wheels, spec, scale, sign, action, wheel_state=state)

    # -- controls ----------------------------------------------------------------------------
    def control(self, steer: float, gas: float, brake: float) -> None:
        """steer -1..1 (+ right as CarRacing's action, or + left: ``build``'s ``steer_left``),
        gas 0..1, brake 0..1."""
        self.steer_target = steer * self.steer_action
        gas, rise = min(max(gas, 0.0), 1.0), self.spec.gas_rise
        state = self.wheel_state  # (Python here: cheaper than a compiled call's arguments)
        left, right = state[GAS, 2:].tolist()  # the rear wheels
        state[GAS, 2:] = (left + min(gas - left, rise), right + min(gas - right, rise))
        state[BRAKE] = brake

    # -- physics -----------------------------------------------------------------------------
    def __post_init__(self) -> None:
        self._prepare()

    def __getstate__(self) -> dict[str, object]:
        # the kernel is chosen again after unpickling (numba may be missing there)
        # and the body's chipmunk pointer is found again
        return {**self.__dict__, "_forces": None, "kernel": None, "_cp": None}

    def _prepare(self) -> None:
        """Per-car constants of the hot path, each computed as the formula it replaces would."""
        spec, scale, body = self.spec, self.scale, self.body
        cx, cy = body.center_of_gravity
        road = spec.friction_limit * scale * 1.0  # [mass track units/s^2]
        grass = spec.friction_limit * scale * spec.grass_friction
        # per wheel: offset from the CoG [track units]; road, grass: (grip, skid threshold)
        self._offsets = [(w.x - cx, w.y - cy) for w in self.wheels]
        self._limits = ((road, spec.skid_ratio * road), (grass, spec.skid_ratio * grass))
        self._radius = self.wheel_radius  # [track units]
        self._spin_moment = spec.wheel_moment * scale**2  # [mass track units^2]
        self._mass, self._moment = body.mass, body.moment  # the shapes are fixed once built
        self._dims = _footprint(scale)  # (rear axle, wheelbase, width) [track units]
        self._spots = [(w.x, w.y) for w in self.wheels]  # wheels in the body's frame
        self._radii = [self._radius] * len(self.wheels)
        self._consts = np.array(car_constants(self)).reshape(CONSTANTS, 1)
        self.kernel: str | None = None  # the tyre model's path, chosen at the first step
        self._forces: Forces | None = None
        self._cp: Any = None  # the body's chipmunk pointer (see ``_pointer``)

    def _pointer(self) -> Any:
        """The body's chipmunk pointer, for the direct reads and sets of the hot path."""
        self._cp = self.body._body
        return self._cp

    def _choose_kernel(self) -> Forces:
        """The tyre model's path (``physics_kernel``), chosen once per car."""
        self.kernel, self._forces = physics_kernel()
        return self._forces

    def apply_forces(self, dt: float, on_road: Sequence[bool]) -> None:
        """Spin the wheels, compute tyre forces and set the body's new velocities.

        Box2D updates velocities before positions (semi-implicit Euler); pymunk moves
        positions with the old velocities first, so the velocities change now (setting
        ``body.force`` would leave the car one step behind the reference). Skid marks
        follow, for the wheels that skid or have a mark open.
        """
        forces = self._forces or self._choose_kernel()
        cp = self._cp or self._pointer()
        velocity = _get_velocity(cp)
        road = on_road[0] | on_road[1] << 1 | on_road[2] << 2 | on_road[3] << 3
        vx, vy, spin, skids = forces(
            self.wheel_state, self._consts, dt, _get_angle(cp), _get_spin(cp), velocity.x,
            velocity.y, self.steer_target, road,
        )  # fmt: skip
        _put_velocity(cp, (vx, vy))  # as pymunk's setters: the body wakes
        _put_spin(cp, spin)
        if skids or any(self._skid_start) or any(self._skid_open):
            for index, wheel in enumerate(self.wheels):
                self._track_skid(index, wheel, bool(on_road[index]))

    def stop(self) -> None:
        """A crash: body and wheels stand still."""
        self.body.velocity, self.body.angular_velocity = (0.0, 0.0), 0.0
        self.wheel_state[OMEGA] = 0.0

    @property
    def wheel_radius(self) -> float:
        """[track units]"""
        return WHEEL_RADIUS * SIZE * self.scale

    def _track_skid(self, index: int, wheel: Wheel, on_road: bool) -> None:
        """Skid marks: polylines where the tyre force exceeds twice the friction limit."""
        if not wheel.skidding:
            self._skid_open[index] = self._skid_start[index] = None
            return
        world = self.body.local_to_world((wheel.x, wheel.y))
        point = (world.x, world.y)
        handle = self._skid_open[index]
        if handle and self.skids.extend(handle, point, not on_road):
            return
        first = self._skid_start[index]
        if first is None:
            self._skid_open[index], self._skid_start[index] = None, point
        else:
            self._skid_open[index] = self.skids.start(first, point, not on_road)
            self._skid_start[index] = None

    # -- state -------------------------------------------------------------------------------
    def state(self) -> CarState:
        """A copy of the car's state for sensors and pictures (the body read once: per step)."""
        cp = self._cp or self._pointer()
        position, velocity = _get_position(cp), _get_velocity(cp)
        x, y, vx, vy = position.x, position.y, velocity.x, velocity.y
        angle = _get_angle(cp)
        rear, base, width = self._dims
        # the axles lie on the body's y axis: body.local_to_world((0, r)) computes
        # (x - sin * r, y + cos * r) with the same libm sin and cos, so the bits are the same
        cos_a, sin_a = math.cos(angle), math.sin(angle)
        front = rear + base
        omegas, steers = self.wheel_state[:2].tolist()  # rows OMEGA, STEER
        return CarState(
            model="dynamic",
            pose=(x, y, angle + math.pi / 2),
            velocity=(vx, vy),
            speed=math.sqrt(vx**2 + vy**2),  # as pymunk's Vec2d.length
            yaw_rate=_get_spin(cp),
            steer=steers[0],
            front_axle=(x - sin_a * front, y + cos_a * front),
            rear_axle=(x - sin_a * rear, y + cos_a * rear),
            footprint=(base, width),
            wheels=tuple(map(WheelState, omegas, steers, self._radii, self._spots)),
            hull_angle=angle,
            scale=self.scale,
            steer_sign=self.steer_sign,
            skids=self.skids.view(),
        )

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, heading) in track units; heading is the forward direction's angle from +x."""
        x, y = self.body.position
        return x, y, self.body.angle + math.pi / 2

    @property
    def speed(self) -> float:
        """[track units/s] of the body."""
        return abs(self.body.velocity)

    @property
    def footprint(self) -> tuple[float, float]:
        """(wheelbase, track width) of the obstacle footprint, in track units."""
        _, base, width = _footprint(self.scale)
        return base, width

    @property
    def rear_axle(self) -> tuple[float, float]:
        """Middle of the rear axle in track units (the footprint's back edge)."""
        rear, _, _ = _footprint(self.scale)
        point = self.body.local_to_world((0.0, rear))
        return point.x, point.y

    @property
    def front_axle(self) -> tuple[float, float]:
        """Middle of the front axle in track units (where cameras are mounted)."""
        rear, base, _ = _footprint(self.scale)
        point = self.body.local_to_world((0.0, rear + base))
        return point.x, point.y


def physics_kernel(wanted: str | None = None) -> tuple[str, Forces]:
    """The tyre model's path ``wanted`` (auto | numba | python; None: ``TINYRACE_PHYSICS``'s,
    else auto), by name, with its ``car_forces``: auto is ``numba`` when numba imports
    (a dependency of tinyrace), else ``python``. Same results."""
    name, module = kernels.choose(
        PHYSICS_VARIABLE, "python", "tinyrace.cars.kernels.dynamic", wanted
    )
    return name, dynamic_python.car_forces if module is None else typed(Forces, module.car_forces)


def _footprint(scale: float) -> tuple[float, float, float]:
    """Rear axle offset on the forward axis, wheelbase, outer wheel track [track units]."""
    unit = SIZE * scale
    rear = WHEEL_POSITIONS[2][1] * unit
    base = (WHEEL_POSITIONS[0][1] - WHEEL_POSITIONS[2][1]) * unit
    width = 2 * (WHEEL_POSITIONS[1][0] + WHEEL_HALF_WIDTH) * unit
    return rear, base, width


def _hull_shape(
    body: pymunk.Body, polygon: tuple[tuple[int, int], ...], unit: float, density: float
) -> pymunk.Poly:
    shape = pymunk.Poly(body, [(x * unit, y * unit) for x, y in polygon])
    shape.density = density
    shape.filter = NOTHING  # the hull only carries mass; nothing in CarRacing collides with it
    return shape


def _wheel_sensor(
    body: pymunk.Body, index: int, wx: float, wy: float, unit: float, density: float
) -> pymunk.Poly:
    """The wheel's footprint (unsteered): a sensor that finds the tiles under it, and its mass."""
    half_w, half_r = WHEEL_HALF_WIDTH * unit, WHEEL_RADIUS * unit
    cx, cy = wx * unit, wy * unit
    corners = [
        (cx - half_w, cy - half_r),
        (cx + half_w, cy - half_r),
        (cx + half_w, cy + half_r),
        (cx - half_w, cy + half_r),
    ]
    shape = pymunk.Poly(body, corners)
    shape.density = density
    shape.sensor = True
    shape.collision_type = WHEEL
    shape.filter = WHEEL_FILTER
    shape.index = index
    return shape
