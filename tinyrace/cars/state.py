"""A car's state as sensors and pictures read it: copies, never the live pymunk body.

Everything here is plain data (floats, tuples, read-only arrays), so that the layers
above the world can read a car without importing the physics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

Point = tuple[float, float]  # [track units]
Pose = tuple[float, float, float]  # (x, y [track units], heading [rad] from +x)


class WheelState(NamedTuple):
    """One wheel of a car that models its wheels (a tuple: four are made every step)."""

    omega: float  # [rad/s] spin
    steer: float  # [rad] steering angle, + turns toward growing heading
    radius: float  # [track units]
    position: Point = (0.0, 0.0)  # [track units] in the hull's frame (see CarState.hull_angle)


@dataclass(frozen=True, eq=False)
class SkidView:
    """Read-only views of a car's skid-mark ring (they follow the car: not a copy).

    Mark ``i`` is ``points[i, :lengths[i]]`` [track units]; ``lengths[i] == 0``: no mark.
    """

    points: np.ndarray  # (marks, max points, 2) float
    lengths: np.ndarray  # (marks,) int
    on_grass: np.ndarray  # (marks,) bool: drawn in mud colour


@dataclass(frozen=True)
class CarFacts:
    """A car model's size, limits and abilities for one config, in the track's units (px, m
    or u): what sensors and drivers ask of a car before it drives (the registry answers)."""

    length: float  # [track units] rear to front axle (sensor ranges, camera mounts, drivers)
    width: float  # [track units]
    top_speed: float  # [track units/s] the most it drives (the dynamic car: its per-step cap)
    yaw_rate: float  # [rad/s] the largest yaw rate
    steer_lock: float  # [rad] the front wheels' largest angle
    steer_per_rad: float  # steering action per rad of front-wheel angle to the right
    grip: float = math.inf  # [track units/s^2] the acceleration its tyres hold (inf: no slip)
    wheels: bool = False  # models its four wheels (wheel speeds and slip; tiles give grip)
    throttle: bool = True  # its speed follows the actions (False: a constant speed)
    lidar_mount: str = "front_axle"  # where a lidar sits when its config names no mount


def read_only(array: np.ndarray) -> np.ndarray:
    """A view of ``array`` that cannot be written through."""
    view: np.ndarray = array.view()
    view.flags.writeable = False
    return view


class CarState(NamedTuple):
    """A copy of one car's state: what sensors and pictures read, never the live body.

    A named tuple (immutable, made every step at a fraction of a frozen dataclass's cost).
    """

    model: str  # the car model's registry name
    pose: Pose  # the car's reference point and heading (see ``Car.pose``)
    velocity: Point  # [track units/s] of the body, in the track frame
    speed: float  # [track units/s] the car's own speed (the kinematic car's set speed)
    yaw_rate: float  # [rad/s] d(heading)/dt
    steer: float  # [rad] front-wheel angle, + turns toward growing heading
    front_axle: Point  # middle of the front axle (where cameras are mounted)
    rear_axle: Point  # middle of the rear axle
    footprint: tuple[float, float]  # (length rear to front axle, width) [track units]
    wheels: tuple[WheelState, ...] = ()  # FL, FR, RL, RR on the dynamic car; () if not modelled
    hull_angle: float = 0.0  # [rad] the body's angle at ``pose``'s point (pictures turn by it)
    scale: float = 1.0  # [track units per CarRacing u] the dynamic car's size on the track
    steer_sign: float = 1.0  # +1 with y up, -1 on a y-down picture (shown directions)
    skids: SkidView | None = None  # skid marks, on cars that leave them


def footprint_points(car: CarState) -> list[tuple[float, float]]:
    """The 4 corners of the car's footprint as plain floats: its width wide, rear axle to
    front axle (per step and car in a race's pictures, where an array costs more)."""
    x, y = car.rear_axle
    heading = car.pose[2]
    length, width = car.footprint
    fx, fy = math.cos(heading), math.sin(heading)
    rx, ry = -fy * width / 2, fx * width / 2  # half the width to the right (y down)
    ax, ay = length * fx, length * fy
    return [
        (x - rx, y - ry),
        (x + rx, y + ry),
        (x + rx + ax, y + ry + ay),
        (x - rx + ax, y - ry + ay),
    ]


def footprint_corners(car: CarState) -> np.ndarray:
    """(4, 2) corners of the car's footprint: its width wide, rear axle to front axle."""
    return np.array(footprint_points(car))
