"""Compiled tyre model (numba): ``DynamicCar.apply_forces``'s arithmetic, bit for bit.

Imported only when a dynamic car first applies its forces and numba imports
(a dependency of tinyrace); see ``dynamic.physics_kernel``. One per-car function,
``_forces``, does a car's step of the tyre model: wheel spin from gas and brake, slip forces
capped by the friction limit, the summed force and torque, the velocity update with
Box2D's speed cap, steering toward the target and the skid flags. ``car_forces`` runs it
for one car (``DynamicCar``), ``batch_forces`` for every row of a ``DynamicBatch``: the
same code on the same arrays.

Arrays (see ``dynamic_layout``): ``state`` (FIELDS, 4 n) holds the wheels' omega, steer,
gas, brake, phase and skid flag, wheel by wheel (column ``wheel * n + row``); ``consts``
(CONSTANTS, n) each car's constants. Every formula keeps the Python path's operation
order; ``min``, ``max`` and ``math.hypot`` are written out as CPython computes them (its
hypot is its own algorithm, not the C library's). No fastmath: LLVM neither reorders
nor fuses (FMA) the float operations.

numba compiles on first use and caches the machine code beside this module (or in
numba's user cache directory; uncached when neither is writable).
"""

from __future__ import annotations

import math
import sys
from typing import Any

from tinyrace.cars.dynamic_layout import (
    BRAKE,
    BRAKE_LOCK,
    BRAKE_RATE,
    ENGINE_POWER,
    GAS,
    GAS_RISE,
    GRASS_LIMIT,
    GRASS_SKID,
    MASS,
    MOMENT,
    OFFSET_X,
    OFFSET_Y,
    OMEGA,
    PHASE,
    RADIUS,
    ROAD_LIMIT,
    ROAD_SKID,
    SKID,
    SLIP_GAIN,
    SPIN_FLOOR,
    SPIN_MOMENT,
    STEER,
    STEER_GAIN,
    STEER_LIMIT,
    STEER_SPEED,
    TRANSLATION,
    WHEEL_MOMENT,
    WHEELS,
)
from tinyrace.kernels.compiled import compiler

_compile = compiler("tyre")
SPLIT = 134217729.0  # 2**27 + 1: Veltkamp's split of a double into two halves
HYPOT_FMA_STYLE = sys.version_info >= (3, 12)  # CPython 3.12 changed hypot's squaring


@_compile
def _min(a: float, b: float) -> float:
    """Python's ``min(a, b)``: ``b`` only when it compares smaller (NaN as Python)."""
    return b if b < a else a


@_compile
def _max(a: float, b: float) -> float:
    """Python's ``max(a, b)``: ``b`` only when it compares larger."""
    return b if b > a else a


@_compile
def _two_product(a: float, b: float) -> tuple[float, float]:
    """(a * b rounded, its exact rounding error), by Dekker's splitting (no fma)."""
    product = a * b
    t = a * SPLIT
    a_hi = t - (t - a)
    a_lo = a - a_hi
    t = b * SPLIT
    b_hi = t - (t - b)
    b_lo = b - b_hi
    error = ((a_hi * b_hi - product) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo
    return product, error


@_compile
def _norm_311(x: float, y: float, scale: float) -> float:
    """CPython 3.10/3.11's vector_norm of (x, y) (>= 0; ``scale`` the power of two that
    brings the larger into [0.5, 1)): split squares, compensated sums, and one
    differential correction of the square root."""
    csum, frac1, frac2, frac3 = 1.0, 0.0, 0.0, 0.0
    for value in (x, y):
        v = value * scale
        t = v * SPLIT
        hi = t - (t - v)
        lo = v - hi
        term = hi * hi
        old = csum
        csum += term
        frac1 += (old - csum) + term
        term = 2.0 * hi * lo
        old = csum
        csum += term
        frac2 += (old - csum) + term
        frac3 += lo * lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2 + frac3))
    t = h * SPLIT
    hi = t - (t - h)
    lo = h - hi
    term = -hi * hi
    old = csum
    csum += term
    frac1 += (old - csum) + term
    term = -2.0 * hi * lo
    old = csum
    csum += term
    frac2 += (old - csum) + term
    term = -lo * lo
    old = csum
    csum += term
    frac3 += (old - csum) + term
    rest = csum - 1.0 + (frac1 + frac2 + frac3)
    return (h + rest / (2.0 * h)) / scale


@_compile
def _norm_312(x: float, y: float, scale: float) -> float:
    """CPython 3.12's vector_norm of (x, y): exact squares (its fma, here Dekker's product:
    the same two numbers), compensated sums, one differential correction."""
    csum, frac1, frac2 = 1.0, 0.0, 0.0
    for value in (x, y):
        v = value * scale
        square, square_lo = _two_product(v, v)
        total = csum + square
        frac2 += (csum - total) + square
        csum = total
        frac1 += square_lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    square, square_lo = _two_product(-h, h)
    total = csum + square
    frac2 += (csum - total) + square
    csum = total
    frac1 += square_lo
    rest = csum - 1.0 + (frac1 + frac2)
    h += rest / (2.0 * h)
    return h / scale


@_compile
def _subnormal_311(x: float, y: float, big: float) -> float:
    """CPython 3.11's vector_norm of (x, y) when the larger is subnormal: each divided by
    it, the squares summed with one compensation term."""
    csum, frac = 1.0, 0.0
    for value in (x, y):
        v = value / big
        v = v * v
        old = csum
        csum += v
        frac += (old - csum) + v
    return big * math.sqrt(csum - 1.0 + frac)


@_compile
def hypot(x: float, y: float) -> float:
    """``math.hypot(x, y)`` as CPython computes it, bit for bit."""
    x, y = abs(x), abs(y)
    big = 0.0  # the largest, found as CPython finds it (a NaN is never larger)
    if x > big:
        big = x
    if y > big:
        big = y
    if math.isinf(big):
        return big
    if math.isnan(x) or math.isnan(y):
        return math.nan
    if big == 0.0:
        return big
    _, exponent = math.frexp(big)
    if exponent < -1023:  # subnormals (never met by a car), as each CPython treats them
        if HYPOT_FMA_STYLE:  # 3.12+: scaled up to normal numbers first
            tiny = 2.2250738585072014e-308  # DBL_MIN
            return tiny * hypot(x / tiny, y / tiny)
        return _subnormal_311(x, y, big)
    scale = math.ldexp(1.0, -exponent)
    if HYPOT_FMA_STYLE:
        return _norm_312(x, y, scale)
    return _norm_311(x, y, scale)


@_compile
def _forces(
    state: Any, consts: Any, row: int, dt: float, angle: float, spin: float, vx: float,
    vy: float, target: float, road: int,
) -> tuple[float, float, float, int]:  # fmt: skip
    """One car's step of the tyre model (``DynamicCar._python_forces``, formula by formula):
    the wheels' spin, phase, skid flags and steering updated in ``state``; returns the
    body's new (vx, vy, angular velocity) and a bit per skidding wheel. ``road``: a bit per
    wheel on road (else grass)."""
    n = consts.shape[1]
    radius, gain = consts[RADIUS, row], consts[SLIP_GAIN, row]
    moment = consts[SPIN_MOMENT, row]
    drive = dt * consts[ENGINE_POWER, row]
    inertia, floor = consts[WHEEL_MOMENT, row], consts[SPIN_FLOOR, row]
    lock, brake_rate = consts[BRAKE_LOCK, row], consts[BRAKE_RATE, row]
    cos_a, sin_a = math.cos(angle), math.sin(angle)
    fx_total = fy_total = torque = 0.0
    skids = 0
    for index in range(WHEELS):
        k = index * n + row
        omega = state[OMEGA, k]
        omega += drive * state[GAS, k] / inertia / (abs(omega) + floor)
        brake = state[BRAKE, k]
        if brake >= lock:
            omega = 0.0
        elif brake > 0:
            omega -= math.copysign(_min(brake_rate * brake, abs(omega)), omega)
        state[PHASE, k] += omega * dt
        lx, ly = consts[OFFSET_X + index, row], consts[OFFSET_Y + index, row]
        rx, ry = cos_a * lx - sin_a * ly, sin_a * lx + cos_a * ly
        wvx, wvy = vx - spin * ry, vy + spin * rx
        steer = state[STEER, k]
        if steer != 0.0:  # a float's truth in Python (NaN is true: unordered !=)
            heading = angle + steer
            side_x, side_y = math.cos(heading), math.sin(heading)
        else:
            side_x, side_y = cos_a, sin_a
        if road >> index & 1:
            limit, skid_limit = consts[ROAD_LIMIT, row], consts[ROAD_SKID, row]
        else:
            limit, skid_limit = consts[GRASS_LIMIT, row], consts[GRASS_SKID, row]
        f = (omega * radius - (-side_y * wvx + side_x * wvy)) * gain
        p = -(side_x * wvx + side_y * wvy) * gain
        total = hypot(f, p)
        if total > limit:
            f, p = f * limit / total, p * limit / total
        state[OMEGA, k] = omega - dt * f * radius / moment
        fx, fy = p * side_x + f * -side_y, p * side_y + f * side_x
        fx_total, fy_total = fx_total + fx, fy_total + fy
        torque += rx * fy - ry * fx
        skidding = total > skid_limit
        state[SKID, k] = 1.0 if skidding else 0.0
        if skidding:
            skids |= 1 << index
    # the velocities (DynamicCar._accelerate), with Box2D's speed cap
    mass = consts[MASS, row]
    vx, vy = vx + fx_total / mass * dt, vy + fy_total / mass * dt
    cap = consts[TRANSLATION, row] / dt
    speed = hypot(vx, vy)
    if speed > cap:
        vx, vy = vx * cap / speed, vy * cap / speed
    turning = spin + torque / consts[MOMENT, row] * dt
    # the front wheels turn toward the target (DynamicCar._steer)
    steer_gain, steer_speed = consts[STEER_GAIN, row], consts[STEER_SPEED, row]
    steer_limit = consts[STEER_LIMIT, row]
    for index in range(2):
        k = index * n + row
        error = target - state[STEER, k]
        rate = math.copysign(_min(steer_gain * abs(error), steer_speed), error)
        state[STEER, k] = _min(_max(state[STEER, k] + rate * dt, -steer_limit), steer_limit)
    return vx, vy, turning, skids


@_compile
def car_forces(
    state: Any, consts: Any, dt: float, angle: float, spin: float, vx: float, vy: float,
    target: float, road: int,
) -> tuple[float, float, float, int]:  # fmt: skip
    """One car's step (arrays of one row): (vx, vy, angular velocity, skidding wheels' bits)."""
    return _forces(state, consts, 0, dt, angle, spin, vx, vy, target, road)


@_compile
def batch_forces(
    state: Any, consts: Any, dt: Any, motion: Any, targets: Any, on_road: Any, out: Any
) -> int:
    """Every row's step: ``motion`` (4, n) the bodies' angle, angular velocity, vx, vy;
    ``on_road`` (n, 4) bool; ``out`` (3, n) gets the new vx, vy and angular velocity.
    Returns the number of skidding wheels."""
    skidding = 0
    for row in range(consts.shape[1]):
        road = 0
        for index in range(WHEELS):
            if on_road[row, index]:
                road |= 1 << index
        vx, vy, turning, skids = _forces(
            state, consts, row, dt[row], motion[0, row], motion[1, row], motion[2, row],
            motion[3, row], targets[row], road,
        )  # fmt: skip
        out[0, row], out[1, row], out[2, row] = vx, vy, turning
        while skids:
            skidding += skids & 1
            skids >>= 1
    return skidding


@_compile
def control(state: Any, consts: Any, row: int, gas: float, brake: float) -> None:
    """``DynamicCar.control``'s wheel part for one row: the rear wheels' gas rises toward
    ``gas`` (already clipped to 0..1) by at most the spec's rise, every wheel brakes."""
    n = consts.shape[1]
    rise = consts[GAS_RISE, row]
    for index in range(2, WHEELS):
        k = index * n + row
        state[GAS, k] += _min(gas - state[GAS, k], rise)
    for index in range(WHEELS):
        state[BRAKE, index * n + row] = brake


@_compile
def batch_control(state: Any, consts: Any, gas: Any, brake: Any) -> None:
    """``control`` for every row: ``gas``, ``brake`` one per row (gas clipped here)."""
    for row in range(consts.shape[1]):
        control(state, consts, row, _min(_max(gas[row], 0.0), 1.0), brake[row])


def compiled_hypot(x: float, y: float) -> float:
    """The kernel's hypot, callable from Python (for tests)."""
    return float(hypot(x, y))
