"""A car's state as sensors and pictures read it: copies, never the live pymunk body."""

from __future__ import annotations

from dataclasses import dataclass

Point = tuple[float, float]  # [track units]
Pose = tuple[float, float, float]  # (x, y [track units], heading [rad] from +x)


@dataclass(frozen=True)
class WheelState:
    """One wheel of a car that models its wheels."""

    omega: float  # [rad/s] spin
    steer: float  # [rad] steering angle, + turns toward growing heading
    radius: float  # [track units]


@dataclass(frozen=True)
class CarState:
    """A copy of one car's state: what sensors and pictures read, never the live body."""

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
