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
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pymunk

from tinyrace.cars.collision import NOTHING, WHEEL, WHEEL_FILTER, footprint_sensor
from tinyrace.cars.dynamic_shape import (
    HULL_POLYGONS,
    SIZE,
    WHEEL_HALF_WIDTH,
    WHEEL_POSITIONS,
    WHEEL_RADIUS,
    DynamicCarSpec,
)
from tinyrace.cars.state import CarState, Point, SkidView, WheelState, read_only


@dataclass
class Wheel:
    """One wheel's own state; position is in the body's frame (track units)."""

    x: float
    y: float
    omega: float = 0.0  # [rad/s] spin
    steer: float = 0.0  # [rad] steering angle (front wheels)
    gas: float = 0.0  # 0..1 (rear wheels)
    brake: float = 0.0  # 0..1
    phase: float = 0.0  # [rad] accumulated spin, for drawing
    skidding: bool = False


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


@dataclass
class DynamicCar:
    """The car: a pymunk body plus wheel states. Controls are set, then ``apply_forces(dt)``."""

    body: pymunk.Body
    wheels: list[Wheel]
    spec: DynamicCarSpec
    scale: float  # [track units per u]
    steer_sign: float  # +1 in CarRacing's y-up frame, -1 on a y-down image
    steer_target: float = 0.0  # [rad] internal sign (positive: counter-clockwise)
    skids: SkidMarks = field(default_factory=SkidMarks)
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
    ) -> DynamicCar:
        """Add a car at ``pose`` (x, y, heading: the forward direction's angle from +x)."""
        body = pymunk.Body()
        x, y, heading = pose
        body.position = (x, y)
        body.angle = heading - math.pi / 2  # the model's nose points along its +y axis
        unit = SIZE * scale  # [track units per model unit]
        shapes = [
            _hull_shape(body, poly, unit, spec.hull_density / scale**2) for poly in HULL_POLYGONS
        ]
        wheels = []
        for index, (wx, wy) in enumerate(WHEEL_POSITIONS):
            wheels.append(Wheel(wx * unit, wy * unit))
            shapes.append(_wheel_sensor(body, index, wx, wy, unit, spec.wheel_density / scale**2))
        rear, base, width = _footprint(scale)
        shapes.append(footprint_sensor(body, (-width / 2, rear), (width / 2, rear + base)))
        space.add(body, *shapes)
        return cls(body, wheels, spec, scale, steer_sign=-1.0 if y_down else 1.0)

    # -- controls ----------------------------------------------------------------------------
    def control(self, steer: float, gas: float, brake: float) -> None:
        """steer -1 (left) .. 1 (right), gas 0..1, brake 0..1, as CarRacing's action."""
        self.steer_target = -steer * self.steer_sign
        gas, rise = min(max(gas, 0.0), 1.0), self.spec.gas_rise
        wheels = self.wheels
        for wheel in wheels[2:]:
            wheel.gas += min(gas - wheel.gas, rise)
        for wheel in wheels:
            wheel.brake = brake

    # -- physics -----------------------------------------------------------------------------
    def __post_init__(self) -> None:
        self._prepare()

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
        self._cap_dt = (0.0, 0.0)  # (dt, Box2D's speed cap at that dt [track units/s])
        self._dims = _footprint(scale)  # (rear axle, wheelbase, width) [track units]
        self._spots = [(w.x, w.y) for w in self.wheels]  # wheels in the body's frame

    def apply_forces(self, dt: float, on_road: Sequence[bool]) -> None:
        """Spin the wheels, compute tyre forces and set them on the body for the next space step.

        Written for speed: the body is read once, the four wheels' math is straight scalar
        code and the summed force changes the velocities once. Each formula keeps the
        operation order of CarRacing's model, so results are bit-identical to it.
        """
        spec, body = self.spec, self.body
        angle, spin = body.angle, body.angular_velocity
        vx, vy = body.velocity
        cos_a, sin_a = math.cos(angle), math.sin(angle)
        radius, gain, moment = self._radius, spec.slip_gain, self._spin_moment
        drive = dt * spec.engine_power  # [mass u^2/s^2] per unit of gas
        inertia, floor = spec.wheel_moment, spec.spin_floor
        lock, brake_rate = spec.brake_lock, spec.brake_rate
        road_limits, grass_limits = self._limits
        offsets, starts, opens = self._offsets, self._skid_start, self._skid_open
        fx_total = fy_total = torque = 0.0
        for index, wheel in enumerate(self.wheels):
            # engine and brake act on the wheel's spin
            omega = wheel.omega
            omega += drive * wheel.gas / inertia / (abs(omega) + floor)
            brake = wheel.brake
            if brake >= lock:
                omega = 0.0
            elif brake > 0:
                omega -= math.copysign(min(brake_rate * brake, abs(omega)), omega)
            wheel.phase += omega * dt
            lx, ly = offsets[index]
            rx, ry = cos_a * lx - sin_a * ly, sin_a * lx + cos_a * ly  # world frame
            wvx, wvy = vx - spin * ry, vy + spin * rx
            steer = wheel.steer
            if steer:
                heading = angle + steer
                side_x, side_y = math.cos(heading), math.sin(heading)
            else:  # angle + 0.0 is angle: the hull's own axes
                side_x, side_y = cos_a, sin_a
            road = on_road[index]
            limit, skid_limit = road_limits if road else grass_limits
            # tyre force from slip, capped at the friction limit (forward f, sideways p)
            f = (omega * radius - (-side_y * wvx + side_x * wvy)) * gain
            p = -(side_x * wvx + side_y * wvy) * gain
            total = math.hypot(f, p)
            if total > limit:
                f, p = f * limit / total, p * limit / total
            wheel.omega = omega - dt * f * radius / moment
            fx, fy = p * side_x + f * -side_y, p * side_y + f * side_x
            fx_total, fy_total = fx_total + fx, fy_total + fy
            torque += rx * fy - ry * fx
            skidding = wheel.skidding = total > skid_limit
            if skidding or starts[index] or opens[index]:
                self._track_skid(index, wheel, road)
        self._accelerate(dt, vx, vy, spin, fx_total, fy_total, torque)
        self._steer(dt)

    def _accelerate(
        self, dt: float, vx: float, vy: float, spin: float, fx: float, fy: float, torque: float
    ) -> None:
        """Change the velocities now, so that the coming space step moves with the new ones.

        Box2D updates velocities before positions (semi-implicit Euler); pymunk moves
        positions with the old velocities first. Setting ``body.force`` would leave the
        car one step behind the reference (dt * speed, about 2 u at top speed).
        Box2D also caps a body's travel per step; the same cap keeps the same top speed.
        ``vx, vy, spin`` are the body's velocities now.
        """
        mass = self._mass
        vx, vy = vx + fx / mass * dt, vy + fy / mass * dt
        if self._cap_dt[0] != dt:
            self._cap_dt = (dt, self.spec.max_translation * self.scale / dt)  # [track units/s]
        cap = self._cap_dt[1]
        speed = math.hypot(vx, vy)
        if speed > cap:
            vx, vy = vx * cap / speed, vy * cap / speed
        _set_velocity(self.body, (vx, vy))
        _set_angular_velocity(self.body, spin + torque / self._moment * dt)

    def stop(self) -> None:
        """A crash: body and wheels stand still."""
        self.body.velocity, self.body.angular_velocity = (0.0, 0.0), 0.0
        for wheel in self.wheels:
            wheel.omega = 0.0

    @property
    def wheel_radius(self) -> float:
        """[track units]"""
        return WHEEL_RADIUS * SIZE * self.scale

    def _steer(self, dt: float) -> None:
        """Front wheels turn toward the target like the reference's joint motor."""
        spec, target = self.spec, self.steer_target
        gain, speed, limit = spec.steer_gain, spec.steer_speed, spec.steer_limit
        for wheel in self.wheels[:2]:
            error = target - wheel.steer
            rate = math.copysign(min(gain * abs(error), speed), error)
            wheel.steer = min(max(wheel.steer + rate * dt, -limit), limit)

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
        body = self.body
        x, y = body.position
        vx, vy = body.velocity
        angle = body.angle
        radius = self._radius
        rear, base, width = self._dims
        # the axles lie on the body's y axis: body.local_to_world((0, r)) computes
        # (x - sin * r, y + cos * r) with the same libm sin and cos, so the bits are the same
        cos_a, sin_a = math.cos(angle), math.sin(angle)
        front = rear + base
        wheels = self.wheels
        return CarState(
            model="dynamic",
            pose=(x, y, angle + math.pi / 2),
            velocity=(vx, vy),
            speed=math.sqrt(vx**2 + vy**2),  # as pymunk's Vec2d.length
            yaw_rate=body.angular_velocity,
            steer=wheels[0].steer,
            front_axle=(x - sin_a * front, y + cos_a * front),
            rear_axle=(x - sin_a * rear, y + cos_a * rear),
            footprint=(base, width),
            wheels=tuple(
                [
                    WheelState(w.omega, w.steer, radius, spot)
                    for w, spot in zip(wheels, self._spots, strict=True)
                ]
            ),
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
