"""The tyre model of many dynamic cars as one numpy computation over (cars x 4 wheels).

``DynamicBatch`` holds the wheel state of N ``DynamicCar`` s in arrays (one row per
car) and does what ``DynamicCar.control`` and ``DynamicCar.apply_forces`` do for one
car, for all rows at once: wheel spin, slip forces, friction cap, summed force and
torque, the velocity update with Box2D's speed cap, and steering. Every formula keeps
the scalar path's operation order, so results are bit-identical to it: numpy's
``+ - * /``, ``minimum``, ``maximum`` and ``copysign`` round as Python's float
operations do; ``cos``, ``sin`` and ``hypot`` are Python's own (``math``), mapped
over the elements, since numpy's may differ from them in the last bit.

The arrays are the wheels' state while a batch steps; ``store`` copies a row back to
its car's ``wheel_state`` (which ``DynamicCar.state`` and skid marks read), ``load``
copies a car into a row (after a reset, or when the car was changed by other code).

With numba (``physics_kernel``: ``TINYRACE_PHYSICS`` auto or numba), ``control`` and
``apply_forces`` run ``kernels/dynamic.py``'s compiled kernel over the rows (the one a single
``DynamicCar`` runs); else the numpy computation below, with the same results.

Layout, for speed: numpy's cost per call on arrays this small is its fixed overhead
(thousands of instructions), least when every operand is a contiguous 1-D array of the
same length. So every per-wheel quantity is one flat array of ``4 * size``, wheel by
wheel (index ``wheel * size + row``: the front wheels are the first half, the rear
the second): a row of ``state`` (see ``dynamic_layout``); per-car constants are
repeated per wheel, and per-car results (force, torque, velocity) are arrays of ``size``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pymunk

from tinyrace.cars.base import Car
from tinyrace.cars.dynamic import (
    DynamicCar,
    _set_angular_velocity,
    _set_velocity,
    physics_kernel,
)
from tinyrace.cars.dynamic_layout import (
    BRAKE,
    CONSTANTS,
    GAS,
    OMEGA,
    PHASE,
    SKID,
    STEER,
    WHEELS,
    new_state,
)


def _each(function: Callable[..., float], *arrays: np.ndarray) -> np.ndarray:
    """``function`` (one of Python's ``math``, which numpy's may differ from in the last
    bit) of the arrays' elements, as an array of their shape."""
    values = map(function, *(array.ravel().tolist() for array in arrays))
    return np.array(list(values)).reshape(arrays[0].shape)


def _motion(body: pymunk.Body | None) -> tuple[float, float, float, float, float, float]:
    """A body's (angle, its cos and sin, angular velocity, vx, vy); zeros for no body."""
    if body is None:
        return 0.0, 1.0, 0.0, 0.0, 0.0, 0.0
    angle = body.angle
    vx, vy = body.velocity
    return angle, math.cos(angle), math.sin(angle), body.angular_velocity, vx, vy


def _angle_spin_velocity(body: pymunk.Body | None) -> tuple[float, float, float, float]:
    """A body's (angle, angular velocity, vx, vy); zeros for no body."""
    if body is None:
        return 0.0, 0.0, 0.0, 0.0
    vx, vy = body.velocity
    return body.angle, body.angular_velocity, vx, vy


class DynamicBatch:
    """The wheel states and constants of ``size`` dynamic cars (rows), wheel-major."""

    # per wheel, from each car's spec and scale (see DynamicCar._prepare)
    road_limit: np.ndarray  # [mass track units/s^2] grip on road
    grass_limit: np.ndarray  # on grass
    road_skid: np.ndarray  # skid threshold on road
    grass_skid: np.ndarray  # on grass
    radius: np.ndarray  # [track units]
    spin_moment: np.ndarray  # [mass track units^2]
    slip_gain: np.ndarray
    engine_power: np.ndarray
    wheel_moment: np.ndarray
    spin_floor: np.ndarray
    brake_lock: np.ndarray
    brake_rate: np.ndarray
    gas_rise: np.ndarray
    steer_gain: np.ndarray
    steer_speed: np.ndarray
    steer_limit: np.ndarray
    neg_steer_limit: np.ndarray
    # per car
    mass: np.ndarray
    moment: np.ndarray
    translation: np.ndarray  # [track units per step] Box2D's speed cap
    steer_sign: np.ndarray
    steer_action: np.ndarray

    def __init__(self, size: int) -> None:
        self.size = n = size
        self.cars: list[DynamicCar | None] = [None] * size
        m = WHEELS * n
        self.front, self.rear = slice(0, 2 * n), slice(2 * n, m)
        # wheel state: the rows of one array, changed in place
        self.state = state = new_state(n)
        self.omega = state[OMEGA]  # [rad/s] spin
        self.steer = state[STEER]  # [rad] steering angle (front wheels)
        self.gas = state[GAS]  # 0..1 (rear wheels)
        self.brake = state[BRAKE]  # 0..1
        self.phase = state[PHASE]  # [rad] accumulated spin
        self.skidding = state[SKID]  # 1.0: skidding
        self.tracking = np.zeros(m, bool)  # a skid mark is open or waits for a point
        self.steer_target = np.zeros(n)  # [rad] per car
        # per wheel: offset from the CoG in the body's frame [track units]; the car's
        # constants, repeated per wheel
        self.offset_x, self.offset_y = np.zeros(m), np.zeros(m)
        for name in _WHEEL_CONSTANTS:
            setattr(self, name, np.ones(m))
        for name in _CAR_CONSTANTS:
            setattr(self, name, np.ones(n))
        self._zeros, self._ones = np.zeros(m), np.ones(m)  # for np.where
        self._car_zeros = np.zeros(n)
        # the compiled kernel's inputs: each car's constants (dynamic_layout), the bodies'
        # motion (angle, angular velocity, vx, vy), its outputs (vx, vy, angular velocity)
        self.consts = np.ones((CONSTANTS, n))
        self._motion, self._out = np.zeros((4, n)), np.zeros((3, n))
        self.kernel = physics_kernel()[0]  # numba | python (this numpy computation)
        self._compiled: Any = None
        if self.kernel == "numba":
            from tinyrace.cars.kernels import dynamic as dynamic_numba

            self._compiled = dynamic_numba

    def wheels(self, values: np.ndarray, row: int) -> np.ndarray:
        """The four wheels' entries of ``row`` in a per-wheel array (a view)."""
        return values[row :: self.size]

    # -- rows <-> cars -----------------------------------------------------------------------
    def load(self, row: int, car: Car) -> None:
        """Copy ``car`` (a ``DynamicCar``)'s constants and wheel state into ``row``."""
        if not isinstance(car, DynamicCar):
            raise TypeError(f"a batch of dynamic cars cannot hold a {type(car).__name__}")
        self.cars[row] = car
        spec, n = car.spec, self.size
        (road, road_skid), (grass, grass_skid) = car._limits
        per_wheel = {
            "road_limit": road,
            "grass_limit": grass,
            "road_skid": road_skid,
            "grass_skid": grass_skid,
            "radius": car._radius,
            "spin_moment": car._spin_moment,
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
            "neg_steer_limit": -spec.steer_limit,
        }
        for name, value in per_wheel.items():
            getattr(self, name)[row::n] = value
        per_car = {
            "mass": car._mass,
            "moment": car._moment,
            "translation": spec.max_translation * car.scale,  # [track units per step]
            "steer_sign": car.steer_sign,
            "steer_action": car.steer_action,
        }
        for name, value in per_car.items():
            getattr(self, name)[row] = value
        self.offset_x[row::n] = [x for x, _ in car._offsets]
        self.offset_y[row::n] = [y for _, y in car._offsets]
        self.consts[:, row] = car._consts[:, 0]
        self.state[:, row::n] = car.wheel_state
        self.tracking[row::n] = [
            start is not None or mark is not None
            for start, mark in zip(car._skid_start, car._skid_open, strict=True)
        ]
        self.steer_target[row] = car.steer_target

    def store(self, rows: Sequence[int]) -> None:
        """Copy the wheel state of ``rows`` back to their cars' ``wheel_state``."""
        targets = self.steer_target.tolist()
        state, n = self.state, self.size
        for row in rows:
            car = self.cars[row]
            assert car is not None
            car.steer_target = targets[row]
            car.wheel_state[:] = state[:, row::n]

    # -- controls ----------------------------------------------------------------------------
    def control(self, steer: np.ndarray, gas: np.ndarray, brake: np.ndarray) -> None:
        """Every row's action (``DynamicCar.control``): steer -1..1, gas 0..1, brake 0..1."""
        self.steer_target = steer * self.steer_action
        if self._compiled is not None:
            self._compiled.batch_control(self.state, self.consts, gas, brake)
            return
        gas = np.tile(np.minimum(np.maximum(gas, 0.0), 1.0), 2)  # per rear wheel
        rear = self.gas[self.rear]
        self.gas[self.rear] = rear + np.minimum(gas - rear, self.gas_rise[self.rear])
        self.brake[:] = np.tile(brake, WHEELS)

    # -- physics -----------------------------------------------------------------------------
    def apply_forces(self, dt: np.ndarray, rows: Sequence[int], on_road: np.ndarray) -> None:
        """``DynamicCar.apply_forces`` for every row: the wheels spun and steered in the
        arrays, the new velocities set on the bodies of ``rows`` (the others' results are
        computed but not used: a row that is not stepped is loaded again before its next
        step). ``dt`` [s] per row; ``on_road`` (rows x 4) is each wheel's grip.
        Skid marks are the caller's (``track_skids``), before the space steps."""
        n = self.size
        bodies = [car.body if car is not None else None for car in self.cars]
        if self._compiled is not None:
            self._compiled_forces(bodies, dt, rows, on_road)
            return
        motion = np.array([_motion(body) for body in bodies]).T.copy()  # 6 x rows
        angle, cos_a, sin_a, spin, vx, vy = np.tile(motion, WHEELS)  # per wheel
        dt_wheel = np.tile(dt, WHEELS)
        omega = self._spin_wheels(dt_wheel)
        # world-frame offsets of the wheels, and their ground velocities
        lx, ly = self.offset_x, self.offset_y
        rx, ry = cos_a * lx - sin_a * ly, sin_a * lx + cos_a * ly
        wvx, wvy = vx - spin * ry, vy + spin * rx
        side_x, side_y = self._wheel_axes(angle, cos_a, sin_a)
        road = on_road.T.ravel()  # wheel-major, as the arrays
        limit = np.where(road, self.road_limit, self.grass_limit)
        skid_limit = np.where(road, self.road_skid, self.grass_skid)
        # tyre force from slip, capped at the friction limit (forward f, sideways p)
        gain, radius = self.slip_gain, self.radius
        f = (omega * radius - (-side_y * wvx + side_x * wvy)) * gain
        p = -(side_x * wvx + side_y * wvy) * gain
        total = _each(math.hypot, f, p)
        capped = total > limit
        divisor = np.where(capped, total, self._ones)  # the uncapped keep f, p (no 0 / 0)
        f = np.where(capped, f * limit / divisor, f)
        p = np.where(capped, p * limit / divisor, p)
        self.omega[:] = omega - dt_wheel * f * radius / self.spin_moment
        fx, fy = p * side_x + f * -side_y, p * side_y + f * side_x
        self.skidding[:] = total > skid_limit
        # force, torque summed over the wheels in order from 0.0, as the scalar loop adds them
        terms = np.concatenate(
            (fx.reshape(WHEELS, n), fy.reshape(WHEELS, n), (rx * fy - ry * fx).reshape(WHEELS, n)),
            axis=1,
        )  # wheels x (fx, fy, torque of each row)
        sums = np.tile(self._car_zeros, 3) + terms[0] + terms[1] + terms[2] + terms[3]
        fx_total, fy_total, torque = sums[:n], sums[n : 2 * n], sums[2 * n :]
        velocity = (motion[4], motion[5], motion[3])
        self._accelerate(bodies, rows, dt, velocity, fx_total, fy_total, torque)
        self._steer(dt_wheel)

    def _compiled_forces(
        self,
        bodies: list[pymunk.Body | None],
        dt: np.ndarray,
        rows: Sequence[int],
        on_road: np.ndarray,
    ) -> None:
        """``apply_forces`` by the compiled kernel (``kernels.dynamic.batch_forces``)."""
        motion, out = self._motion, self._out
        motion[:] = np.array([_angle_spin_velocity(body) for body in bodies]).T
        self._compiled.batch_forces(
            self.state, self.consts, dt, motion, self.steer_target, on_road, out
        )
        vxs, vys, turns = out.tolist()
        for row in rows:
            body = bodies[row]
            _set_velocity(body, (vxs[row], vys[row]))
            _set_angular_velocity(body, turns[row])

    def _spin_wheels(self, dt: np.ndarray) -> np.ndarray:
        """Engine and brake act on the wheels' spin; the spin after them."""
        omega = self.omega
        drive = dt * self.engine_power  # [mass u^2/s^2] per unit of gas
        omega = omega + drive * self.gas / self.wheel_moment / (np.abs(omega) + self.spin_floor)
        brake = self.brake
        braked = omega - np.copysign(np.minimum(self.brake_rate * brake, np.abs(omega)), omega)
        omega = np.where(brake >= self.brake_lock, self._zeros, np.where(brake > 0, braked, omega))
        self.phase[:] = self.phase + omega * dt
        return omega

    def _wheel_axes(
        self, angle: np.ndarray, cos_a: np.ndarray, sin_a: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Each wheel's rolling axis (cos, sin of hull angle + steer); the rear never steer."""
        front = self.front
        steer = self.steer[front]
        turned = steer != 0  # angle + 0.0 is angle: the hull's own axes
        if not turned.any():
            return cos_a, sin_a
        heading = angle[front] + steer
        side_x, side_y = cos_a.copy(), sin_a.copy()
        side_x[front] = np.where(turned, _each(math.cos, heading), cos_a[front])
        side_y[front] = np.where(turned, _each(math.sin, heading), sin_a[front])
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
        mass = self.mass
        vx, vy = vx + fx / mass * dt, vy + fy / mass * dt
        cap = self.translation / dt  # [track units/s] Box2D's speed cap
        speed = _each(math.hypot, vx, vy)
        over = speed > cap
        divisor = np.where(over, speed, self._ones[: self.size])
        vx = np.where(over, vx * cap / divisor, vx)
        vy = np.where(over, vy * cap / divisor, vy)
        turning = spin + torque / self.moment * dt
        vxs, vys, turns = vx.tolist(), vy.tolist(), turning.tolist()
        for row in rows:
            body = bodies[row]
            _set_velocity(body, (vxs[row], vys[row]))
            _set_angular_velocity(body, turns[row])

    def _steer(self, dt: np.ndarray) -> None:
        """Front wheels turn toward the target like the reference's joint motor."""
        front = self.front
        steer = self.steer[front]
        error = np.tile(self.steer_target, 2) - steer
        rate = np.copysign(
            np.minimum(self.steer_gain[front] * np.abs(error), self.steer_speed[front]), error
        )
        turned = np.maximum(steer + rate * dt[front], self.neg_steer_limit[front])
        self.steer[front] = np.minimum(turned, self.steer_limit[front])

    # -- skid marks --------------------------------------------------------------------------
    def track_skids(self, rows: Sequence[int], on_road: np.ndarray) -> None:
        """Skid marks of ``rows`` (stored first): the scalar path for the wheels that skid
        or end a mark, before the space steps (the marks use the body's position now)."""
        busy = np.flatnonzero((self.skidding != 0) | self.tracking).tolist()
        if not busy:
            return
        wanted, n = set(rows), self.size
        for k in busy:  # wheel by wheel: each car's wheels in order, as the scalar loop
            index, row = divmod(k, n)
            car = self.cars[row]
            if row not in wanted or car is None:
                continue
            car._track_skid(index, car.wheels[index], bool(on_road[row, index]))
            started, opened = car._skid_start[index], car._skid_open[index]
            self.tracking[k] = started is not None or opened is not None

    def stop(self, row: int) -> None:
        """A crash (``DynamicCar.stop``): the row's wheels stand still."""
        self.omega[row :: self.size] = 0.0


_WHEEL_CONSTANTS = (
    *("road_limit", "grass_limit", "road_skid", "grass_skid", "radius", "spin_moment"),
    *("slip_gain", "engine_power", "wheel_moment", "spin_floor", "brake_lock", "brake_rate"),
    *("gas_rise", "steer_gain", "steer_speed", "steer_limit", "neg_steer_limit"),
)
_CAR_CONSTANTS = ("mass", "moment", "translation", "steer_sign", "steer_action")
