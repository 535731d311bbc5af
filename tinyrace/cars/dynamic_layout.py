"""Where the dynamic car's tyre model keeps its numbers: the rows of two float64 arrays.

``state`` (FIELDS, 4 n): the wheels' state of n cars, one row per quantity, wheel by wheel
(column ``wheel * n + car``; one car: the column is the wheel). ``DynamicCar`` keeps its
own (FIELDS, 4); ``DynamicBatch`` keeps n cars' and copies rows to and from the cars.
``consts`` (CONSTANTS, n): each car's constants, from its spec and scale, computed as the
formulas they replace would (see ``car_constants``). Plain numbers, no numba: the
compiled kernel (``kernels/dynamic.py``) and the Python paths read the same rows.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from tinyrace.cars.dynamic import DynamicCar

WHEELS = 4  # FL, FR, RL, RR; the first two steer, the last two drive

# state rows
OMEGA = 0  # [rad/s] spin
STEER = 1  # [rad] steering angle (front wheels)
GAS = 2  # 0..1 (rear wheels)
BRAKE = 3  # 0..1
PHASE = 4  # [rad] accumulated spin, for drawing
SKID = 5  # 1.0 when the tyre force passed the skid threshold this step, else 0.0
FIELDS = 6

# consts rows
ROAD_LIMIT = 0  # [mass track units/s^2] grip on road
GRASS_LIMIT = 1  # on grass
ROAD_SKID = 2  # skid threshold on road
GRASS_SKID = 3  # on grass
RADIUS = 4  # [track units] wheel radius
SPIN_MOMENT = 5  # [mass track units^2]
SLIP_GAIN = 6
ENGINE_POWER = 7
WHEEL_MOMENT = 8
SPIN_FLOOR = 9
BRAKE_LOCK = 10
BRAKE_RATE = 11
GAS_RISE = 12
STEER_GAIN = 13
STEER_SPEED = 14
STEER_LIMIT = 15
MASS = 16
MOMENT = 17
TRANSLATION = 18  # [track units per step] Box2D's speed cap
OFFSET_X = 19  # 4 rows: each wheel's offset from the CoG in the body's frame [track units]
OFFSET_Y = 23  # 4 rows
CONSTANTS = 27


def car_constants(car: DynamicCar) -> list[float]:
    """``car``'s constants, in the order of the consts rows."""
    spec = car.spec
    (road, road_skid), (grass, grass_skid) = car._limits
    return [
        road, grass, road_skid, grass_skid, car._radius, car._spin_moment, spec.slip_gain,
        spec.engine_power, spec.wheel_moment, spec.spin_floor, spec.brake_lock,
        spec.brake_rate, spec.gas_rise, spec.steer_gain, spec.steer_speed, spec.steer_limit,
        car._mass, car._moment, spec.max_translation * car.scale,
        *(x for x, _ in car._offsets), *(y for _, y in car._offsets),
    ]  # fmt: skip


def new_state(cars: int) -> np.ndarray:
    """The wheels' state of ``cars`` cars at rest: (FIELDS, 4 cars) zeros."""
    return np.zeros((FIELDS, WHEELS * cars))
