"""tinycarlo's car: a kinematic bicycle at constant speed, no slip.

The body's origin is the middle of the rear axle and its +x axis points forward,
so ``body.angle`` is the heading: 0 along +x, growing clockwise on a y-down image.
A positive steering angle turns the car toward growing headings (right on screen).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymunk

from tinyrace.cars.collision import footprint_sensor
from tinyrace.cars.state import CarState


class RearAxleBicycle:
    """Geometry of a bicycle-model car whose body sits at the middle of its rear axle and
    turns with its heading; shared by the kinematic cars (lengths in track units)."""

    body: pymunk.Body
    wheelbase: float  # [track units] rear to front axle
    track_width: float  # [track units]
    velocity: float  # [track units/s] speed along the heading
    steer: float  # [rad] current wheel angle
    steer_target: float  # [rad]
    max_rate: float | None  # [rad/s] steering rate limit, None: unlimited

    def steer_toward_target(self, dt: float) -> None:
        """Turn the wheel toward its target, at most ``max_rate`` for ``dt`` seconds."""
        change = self.steer_target - self.steer
        if self.max_rate is not None:
            limit = self.max_rate * dt
            change = min(max(change, -limit), limit)
        self.steer += change

    @property
    def pose(self) -> tuple[float, float, float]:
        x, y = self.body.position
        return x, y, self.body.angle

    @property
    def speed(self) -> float:
        return self.velocity

    @property
    def footprint(self) -> tuple[float, float]:
        """(wheelbase, track width) [track units]."""
        return self.wheelbase, self.track_width

    @property
    def rear_axle(self) -> tuple[float, float]:
        x, y = self.body.position
        return x, y

    @property
    def front_axle(self) -> tuple[float, float]:
        x, y = self.body.position
        heading = self.body.angle
        return x + self.wheelbase * math.cos(heading), y + self.wheelbase * math.sin(heading)


@dataclass
class KinematicCar(RearAxleBicycle):
    """Constant-speed bicycle; ``control(steer)`` takes the normalised angle -1..1."""

    body: pymunk.Body
    wheelbase: float  # [px]
    track_width: float  # [px]
    velocity: float  # [px/s]
    max_angle: float  # [rad] full lock
    max_rate: float | None  # [rad/s] steering rate limit, None: unlimited
    steer: float = 0.0  # [rad] current steering angle
    steer_target: float = 0.0  # [rad]

    @classmethod
    def build(
        cls,
        space: pymunk.Space,
        pose: tuple[float, float, float],
        wheelbase: float,
        track_width: float,
        velocity: float,
        max_angle_deg: float,
        max_rate_deg: float | None,
    ) -> KinematicCar:
        # A dynamic body driven by its velocity: pymunk pairs kinematic bodies with no
        # static shape, and the footprint must meet the track's static obstacle sensors.
        body = pymunk.Body(1.0, math.inf)
        x, y, heading = pose
        body.position, body.angle = (x, y), heading
        half = track_width / 2
        space.add(body, footprint_sensor(body, (0.0, -half), (wheelbase, half)))
        rate = None if max_rate_deg is None else math.radians(max_rate_deg)
        return cls(body, wheelbase, track_width, velocity, math.radians(max_angle_deg), rate)

    def control(self, steer: float) -> None:
        self.steer_target = min(max(steer, -1.0), 1.0) * self.max_angle

    def apply_forces(self, dt: float, on_road: object = None) -> None:
        """Move the steering toward its target, then set the velocities for this step."""
        self.steer_toward_target(dt)
        turn_rate = self.velocity * math.tan(self.steer) / self.wheelbase  # [rad/s]
        # pymunk moves the body along a straight line per step: aim it along the chord of the
        # arc the bicycle drives (as tinycarlo steps it), so poses land exactly on that arc
        half_turn = turn_rate * dt / 2  # [rad]
        chord = math.sin(half_turn) / half_turn if half_turn else 1.0  # chord / arc length
        direction = self.body.angle + half_turn
        speed = self.velocity * chord
        self.body.velocity = (speed * math.cos(direction), speed * math.sin(direction))
        self.body.angular_velocity = turn_rate

    def stop(self) -> None:
        """A crash: the body stands still until the next step drives it on at the set speed."""
        self.body.velocity, self.body.angular_velocity = (0.0, 0.0), 0.0

    def state(self) -> CarState:
        """A copy of the car's state for sensors and pictures (body read once: per step)."""
        body = self.body
        x, y = body.position
        heading = body.angle
        vx, vy = body.velocity
        front = (x + self.wheelbase * math.cos(heading), y + self.wheelbase * math.sin(heading))
        return CarState(
            model="kinematic",
            pose=(x, y, heading),
            velocity=(vx, vy),
            speed=self.velocity,
            yaw_rate=body.angular_velocity,
            steer=self.steer,
            front_axle=front,
            rear_axle=(x, y),
            footprint=(self.wheelbase, self.track_width),
            hull_angle=heading,
        )
