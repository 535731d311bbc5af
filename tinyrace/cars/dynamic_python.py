"""The dynamic car's tyre model in Python: CarRacing-v3's formulas, in its operation order.

The reference path (``TINYRACE_PHYSICS=python``, or no numba): the same functions, on the
same arrays (see ``dynamic_layout``), as ``kernels/dynamic.py``'s compiled ones, with the same
results bit for bit. ``car_forces`` steps one car (a state array of one car).
"""

from __future__ import annotations

import math

import numpy as np

from tinyrace.cars.dynamic_layout import WHEELS


def car_forces(
    state: np.ndarray, consts: np.ndarray, dt: float, angle: float, spin: float, vx: float,
    vy: float, target: float, road: int,
) -> tuple[float, float, float, int]:  # fmt: skip
    """One car's step of ``dt`` [s]: wheel spin from gas and brake, tyre forces from slip
    capped at the friction limit (``road``: a bit per wheel on road, else on grass), the
    summed force and torque changing the body's velocities (``angle`` [rad], ``spin``
    [rad/s], ``vx, vy`` [track units/s] now) with Box2D's speed cap, the front wheels
    turned toward ``target`` [rad]. Updates ``state``; returns the new (vx, vy, spin) and
    a bit per skidding wheel."""
    (
        road_limit, grass_limit, road_skid, grass_skid, radius, moment, gain, power, inertia,
        floor, lock, brake_rate, _, steer_gain, steer_speed, steer_limit, mass, body_moment,
        translation, *offsets,
    ) = consts.ravel().tolist()  # fmt: skip
    omegas, steers, gases, brakes, phases, flags = state.tolist()
    cos_a, sin_a = math.cos(angle), math.sin(angle)
    drive = dt * power  # [mass u^2/s^2] per unit of gas
    fx_total = fy_total = torque = 0.0
    skids = 0
    for index in range(WHEELS):
        # engine and brake act on the wheel's spin
        omega = omegas[index]
        omega += drive * gases[index] / inertia / (abs(omega) + floor)
        brake = brakes[index]
        if brake >= lock:
            omega = 0.0
        elif brake > 0:
            omega -= math.copysign(min(brake_rate * brake, abs(omega)), omega)
        phases[index] += omega * dt
        lx, ly = offsets[index], offsets[WHEELS + index]
        rx, ry = cos_a * lx - sin_a * ly, sin_a * lx + cos_a * ly  # world frame
        wvx, wvy = vx - spin * ry, vy + spin * rx
        steer = steers[index]
        if steer:
            heading = angle + steer
            side_x, side_y = math.cos(heading), math.sin(heading)
        else:  # angle + 0.0 is angle: the hull's own axes
            side_x, side_y = cos_a, sin_a
        if road >> index & 1:
            limit, skid_limit = road_limit, road_skid
        else:
            limit, skid_limit = grass_limit, grass_skid
        # tyre force from slip, capped at the friction limit (forward f, sideways p)
        f = (omega * radius - (-side_y * wvx + side_x * wvy)) * gain
        p = -(side_x * wvx + side_y * wvy) * gain
        total = math.hypot(f, p)
        if total > limit:
            f, p = f * limit / total, p * limit / total
        omegas[index] = omega - dt * f * radius / moment
        fx, fy = p * side_x + f * -side_y, p * side_y + f * side_x
        fx_total, fy_total = fx_total + fx, fy_total + fy
        torque += rx * fy - ry * fx
        skidding = total > skid_limit
        flags[index] = 1.0 if skidding else 0.0
        skids |= skidding << index
    # the velocities change now, capped at Box2D's travel per step
    vx, vy = vx + fx_total / mass * dt, vy + fy_total / mass * dt
    cap = translation / dt  # [track units/s]
    speed = math.hypot(vx, vy)
    if speed > cap:
        vx, vy = vx * cap / speed, vy * cap / speed
    turning = spin + torque / body_moment * dt
    # the front wheels turn toward the target like the reference's joint motor
    for index in range(2):
        error = target - steers[index]
        rate = math.copysign(min(steer_gain * abs(error), steer_speed), error)
        steers[index] = min(max(steers[index] + rate * dt, -steer_limit), steer_limit)
    state[:] = (omegas, steers, gases, brakes, phases, flags)
    return vx, vy, turning, skids
