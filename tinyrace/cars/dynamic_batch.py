"""The tyre model of many dynamic cars as one numpy computation over (cars x 4 wheels).

``DynamicBatch`` holds the wheel state of N ``DynamicCar`` s in arrays (one row per
car) and does what ``DynamicCar.control`` and ``DynamicCar.apply_forces`` do for one
car, for all rows at once: wheel spin, slip forces, friction cap, summed force and
torque, the velocity update with Box2D's speed cap, and steering. Every formula keeps
the scalar path's operation order, so results are bit-identical to it: numpy's
``+ - * /``, ``minimum``, ``maximum`` and ``copysign`` round as Python's float
operations do; ``cos``, ``sin`` and ``hypot`` are Python's own (``math``), applied
element by element, since numpy's may differ from them in the last bit.

The arrays are the wheels' state while a batch steps; ``store`` copies a row back to
its car's ``Wheel`` objects (which ``DynamicCar.state`` and skid marks read), ``load``
copies a car into a row (after a reset, or when the car was changed by other code).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pymunk

from tinyrace.cars.dynamic import DynamicCar, _set_angular_velocity, _set_velocity

WHEELS = 4  # FL, FR, RL, RR; the first two steer, the last two drive
FRONT = slice(0, 2)
REAR = slice(2, 4)

# Python's math functions, element by element (numpy's own may round differently)
_cos = np.frompyfunc(math.cos, 1, 1)
_sin = np.frompyfunc(math.sin, 1, 1)
_hypot = np.frompyfunc(math.hypot, 2, 1)


def _motion(body: pymunk.Body | None) -> tuple[float, float, float, float, float, float]:
    """A body's (angle, its cos and sin, angular velocity, vx, vy); zeros for no body."""
    if body is None:
        return 0.0, 1.0, 0.0, 0.0, 0.0, 0.0
    angle = body.angle
    vx, vy = body.velocity
    return angle, math.cos(angle), math.sin(angle), body.angular_velocity, vx, vy


def _float(values: np.ndarray) -> np.ndarray:
    """An object array from a ``frompyfunc`` as float64."""
    return values.astype(np.float64)


class DynamicBatch:
    """The wheel states and per-car constants of ``size`` dynamic cars, one row each."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.cars: list[DynamicCar | None] = [None] * size
        shape = (size, WHEELS)
        # wheel state, per row and wheel
        self.omega = np.zeros(shape)  # [rad/s] spin
        self.steer = np.zeros(shape)  # [rad] steering angle (front wheels)
        self.gas = np.zeros(shape)  # 0..1 (rear wheels)
        self.brake = np.zeros(shape)  # 0..1
        self.phase = np.zeros(shape)  # [rad] accumulated spin
        self.skidding = np.zeros(shape, bool)
        self.tracking = np.zeros(shape, bool)  # a skid mark is open or waits for a point
        self.steer_target = np.zeros(size)  # [rad]
        # per wheel: offset from the CoG in the body's frame [track units]
        self.offset_x = np.zeros(shape)
        self.offset_y = np.zeros(shape)
        # per car constants (columns of one, so that they broadcast over the wheels)
        column = (size, 1)
        names = (
            "road_limit grass_limit road_skid grass_skid radius spin_moment mass moment "
            "slip_gain engine_power wheel_moment spin_floor brake_lock brake_rate gas_rise "
            "steer_gain steer_speed steer_limit translation steer_sign"
        ).split()
        self._constants = names
        for name in names:
            setattr(self, name, np.ones(column))

    # -- rows <-> cars -----------------------------------------------------------------------
    def load(self, row: int, car: DynamicCar) -> None:
        """Copy ``car``'s constants and wheel state into ``row``."""
        self.cars[row] = car
        spec, wheels = car.spec, car.wheels
        (road, road_skid), (grass, grass_skid) = car._limits
        values = {
            "road_limit": road,
            "grass_limit": grass,
            "road_skid": road_skid,
            "grass_skid": grass_skid,
            "radius": car._radius,
            "spin_moment": car._spin_moment,
            "mass": car._mass,
            "moment": car._moment,
            "slip_gain": spec.slip_gain,
            "engine_power": spec.engine_power,
            "wheel_moment": spec.wheel_moment,
            "spin_floor": spec.spin_floor,
            "brake_lock": spec.brake_lock,
            "brake_rate": spec.brake_rate,
            "gas_rise": spec.gas_rise,
            "steer_gain": spec.steer_gain,
            "steer_speed": spec.steer_speed,
            "steer_limit": spec.steer_limit,
            "translation": spec.max_translation * car.scale,  # [track units per step]
            "steer_sign": car.steer_sign,
        }
        for name, value in values.items():
            getattr(self, name)[row, 0] = value
        self.offset_x[row] = [x for x, _ in car._offsets]
        self.offset_y[row] = [y for _, y in car._offsets]
        self.omega[row] = [w.omega for w in wheels]
        self.steer[row] = [w.steer for w in wheels]
        self.gas[row] = [w.gas for w in wheels]
        self.brake[row] = [w.brake for w in wheels]
        self.phase[row] = [w.phase for w in wheels]
        self.skidding[row] = [w.skidding for w in wheels]
        self.tracking[row] = [
            start is not None or mark is not None
            for start, mark in zip(car._skid_start, car._skid_open, strict=True)
        ]
        self.steer_target[row] = car.steer_target

    def store(self, rows: Sequence[int]) -> None:
        """Copy the wheel state of ``rows`` back to their cars' ``Wheel`` objects."""
        omega, steer, gas = self.omega.tolist(), self.steer.tolist(), self.gas.tolist()
        brake, phase, skidding = self.brake.tolist(), self.phase.tolist(), self.skidding.tolist()
        targets = self.steer_target.tolist()
        for row in rows:
            car = self.cars[row]
            assert car is not None
            car.steer_target = targets[row]
            for i, wheel in enumerate(car.wheels):
                wheel.omega, wheel.steer = omega[row][i], steer[row][i]
                wheel.gas, wheel.brake = gas[row][i], brake[row][i]
                wheel.phase, wheel.skidding = phase[row][i], skidding[row][i]

    # -- controls ----------------------------------------------------------------------------
    def control(self, steer: np.ndarray, gas: np.ndarray, brake: np.ndarray) -> None:
        """Every row's action (``DynamicCar.control``): steer -1..1, gas 0..1, brake 0..1."""
        self.steer_target = -steer * self.steer_sign[:, 0]
        gas = np.minimum(np.maximum(gas, 0.0), 1.0)[:, None]
        rear = self.gas[:, REAR]
        self.gas[:, REAR] = rear + np.minimum(gas - rear, self.gas_rise)
        self.brake[:] = brake[:, None]

    # -- physics -----------------------------------------------------------------------------
    def apply_forces(self, dt: np.ndarray, rows: Sequence[int], on_road: np.ndarray) -> None:
        """``DynamicCar.apply_forces`` for every row: the wheels spun and steered in the
        arrays, the new velocities set on the bodies of ``rows`` (the others' results are
        computed but not used: a row that is not stepped is loaded again before its next
        step). ``dt`` [s] per row; ``on_road`` (rows x 4) is each wheel's grip.
        Skid marks are the caller's (``track_skids``), before the space steps."""
        bodies = [car.body if car is not None else None for car in self.cars]
        motion = np.array([_motion(body) for body in bodies])  # rows x (angle cos sin w vx vy)
        angle, cos_a, sin_a, spin, vx, vy = (motion[:, i : i + 1] for i in range(6))
        dt = dt[:, None]
        omega = self._spin_wheels(dt)
        # world-frame offsets of the wheels, and their ground velocities
        lx, ly = self.offset_x, self.offset_y
        rx, ry = cos_a * lx - sin_a * ly, sin_a * lx + cos_a * ly
        wvx, wvy = vx - spin * ry, vy + spin * rx
        side_x, side_y = self._wheel_axes(angle, cos_a, sin_a)
        limit = np.where(on_road, self.road_limit, self.grass_limit)
        skid_limit = np.where(on_road, self.road_skid, self.grass_skid)
        # tyre force from slip, capped at the friction limit (forward f, sideways p)
        gain, radius = self.slip_gain, self.radius
        f = (omega * self.radius - (-side_y * wvx + side_x * wvy)) * gain
        p = -(side_x * wvx + side_y * wvy) * gain
        total = _float(_hypot(f, p))
        capped = total > limit
        divisor = np.where(capped, total, 1.0)  # the uncapped keep f, p (and divide no 0 by 0)
        f = np.where(capped, f * limit / divisor, f)
        p = np.where(capped, p * limit / divisor, p)
        self.omega = omega - dt * f * radius / self.spin_moment
        fx, fy = p * side_x + f * -side_y, p * side_y + f * side_x
        self.skidding = total > skid_limit
        # force, torque summed over the wheels in order from 0.0, as the scalar loop adds them
        terms = np.stack((fx, fy, rx * fy - ry * fx))  # 3 x rows x wheels
        first, second, third, fourth = (terms[..., i] for i in range(WHEELS))
        fx_total, fy_total, torque = 0.0 + first + second + third + fourth
        velocity = (vx[:, 0], vy[:, 0], spin[:, 0])
        self._accelerate(bodies, rows, dt[:, 0], velocity, fx_total, fy_total, torque)
        self._steer(dt)

    def _spin_wheels(self, dt: np.ndarray) -> np.ndarray:
        """Engine and brake act on the wheels' spin; the spin after them."""
        omega = self.omega
        drive = dt * self.engine_power  # [mass u^2/s^2] per unit of gas
        omega = omega + drive * self.gas / self.wheel_moment / (np.abs(omega) + self.spin_floor)
        brake = self.brake
        braked = omega - np.copysign(np.minimum(self.brake_rate * brake, np.abs(omega)), omega)
        omega = np.where(brake >= self.brake_lock, 0.0, np.where(brake > 0, braked, omega))
        self.phase = self.phase + omega * dt
        return omega

    def _wheel_axes(
        self, angle: np.ndarray, cos_a: np.ndarray, sin_a: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Each wheel's rolling axis (cos, sin of hull angle + steer); the rear never steer."""
        side_x = np.repeat(cos_a, WHEELS, axis=1)
        side_y = np.repeat(sin_a, WHEELS, axis=1)
        steer = self.steer[:, FRONT]
        turned = steer != 0  # angle + 0.0 is angle: the hull's own axes
        if turned.any():
            heading = angle + steer
            side_x[:, FRONT] = np.where(turned, _float(_cos(heading)), side_x[:, FRONT])
            side_y[:, FRONT] = np.where(turned, _float(_sin(heading)), side_y[:, FRONT])
        return side_x, side_y

    def _accelerate(
        self,
        bodies: list[pymunk.Body | None],
        rows: Sequence[int],
        dt: np.ndarray,
        velocity: tuple[np.ndarray, np.ndarray, np.ndarray],
        fx: np.ndarray,
        fy: np.ndarray,
        torque: np.ndarray,
    ) -> None:
        """The new velocities (``DynamicCar._accelerate``), set on the bodies of ``rows``."""
        vx, vy, spin = velocity
        mass = self.mass[:, 0]
        vx, vy = vx + fx / mass * dt, vy + fy / mass * dt
        cap = self.translation[:, 0] / dt  # [track units/s] Box2D's speed cap
        speed = _float(_hypot(vx, vy))
        over = speed > cap
        divisor = np.where(over, speed, 1.0)
        vx = np.where(over, vx * cap / divisor, vx)
        vy = np.where(over, vy * cap / divisor, vy)
        turning = spin + torque / self.moment[:, 0] * dt
        vxs, vys, turns = vx.tolist(), vy.tolist(), turning.tolist()
        for row in rows:
            body = bodies[row]
            _set_velocity(body, (vxs[row], vys[row]))
            _set_angular_velocity(body, turns[row])

    def _steer(self, dt: np.ndarray) -> None:
        """Front wheels turn toward the target like the reference's joint motor."""
        steer = self.steer[:, FRONT]
        error = self.steer_target[:, None] - steer
        rate = np.copysign(np.minimum(self.steer_gain * np.abs(error), self.steer_speed), error)
        limit = self.steer_limit
        self.steer[:, FRONT] = np.minimum(np.maximum(steer + rate * dt, -limit), limit)

    # -- skid marks --------------------------------------------------------------------------
    def track_skids(self, rows: Sequence[int], on_road: np.ndarray) -> None:
        """Skid marks of ``rows`` (stored first): the scalar path for the wheels that skid
        or end a mark, before the space steps (the marks use the body's position now)."""
        busy = self.skidding | self.tracking
        if not busy.any():
            return
        wanted = set(rows)
        for row, index in zip(*np.nonzero(busy), strict=True):
            row, index = int(row), int(index)
            car = self.cars[row]
            if row not in wanted or car is None:
                continue
            car._track_skid(index, car.wheels[index], bool(on_road[row, index]))
            started, opened = car._skid_start[index], car._skid_open[index]
            self.tracking[row, index] = started is not None or opened is not None

    def stop(self, row: int) -> None:
        """A crash (``DynamicCar.stop``): the row's wheels stand still."""
        self.omega[row] = 0.0
