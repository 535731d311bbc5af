"""A kinematic bicycle with throttle, in metres (tinycarlo 2's car): no slip, speed from pedals.

Action [steer, throttle], each -1..1: steer +1 turns at full lock (rate-limited when
``max_rate`` is set), left on the metre tracks (``steer_left``, the registry's convention;
tinycarlo 2 turned right); throttle > 0 accelerates at up to ``max_acceleration``,
throttle < 0 brakes at up to ``max_deceleration`` down to a standstill (no reverse);
the speed never exceeds ``max_velocity``. The body's origin is the middle of the rear
axle and ``body.angle`` is the heading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymunk

from tinyrace.cars.collision import footprint_sensor
from tinyrace.cars.kinematic import RearAxleBicycle
from tinyrace.cars.state import CarState


@dataclass
class KinematicThrottleCar(RearAxleBicycle):
    """Bicycle model with a speed state; ``control(steer, throttle)`` takes -1..1 each."""

    body: pymunk.Body
    wheelbase: float  # [m]
    track_width: float  # [m]
    max_velocity: float  # [m/s]
    max_acceleration: float  # [m/s^2]
    max_deceleration: float  # [m/s^2]
    max_angle: float  # [rad] full lock
    max_rate: float | None  # [rad/s] steering rate limit, None: unlimited
    turn_sign: float  # the heading change's sign under a positive steer
    velocity: float = 0.0  # [m/s] current speed along the heading
    steer: float = 0.0  # [rad] current wheel angle, + as a positive steer action
    steer_target: float = 0.0  # [rad]
    throttle: float = 0.0  # -1..1

    @classmethod
    def build(
        cls,
        space: pymunk.Space,
        pose: tuple[float, float, float],
        sizes: tuple[float, float],
        limits: tuple[float, float, float],
        steering: tuple[float, float | None],
        y_down: bool = False,
        steer_left: bool = False,
    ) -> KinematicThrottleCar:
        """A car at ``pose`` (x, y, heading); ``sizes`` (wheelbase, track width) [m],
        ``limits`` (max velocity [m/s], acceleration, deceleration [m/s^2]), ``steering``
        (full lock [deg], rate limit [deg/s] or None); a positive steer turns right, or
        left with ``steer_left``."""
        body = pymunk.Body(1.0, math.inf)  # driven by its velocity (see KinematicCar)
        x, y, heading = pose
        body.position, body.angle = (x, y), heading
        wheelbase, width = sizes
        space.add(body, footprint_sensor(body, (0.0, -width / 2), (wheelbase, width / 2)))
        lock, rate = steering
        return cls(
            body,
            wheelbase,
            width,
            *limits,
            math.radians(lock),
            None if rate is None else math.radians(rate),
            (1.0 if y_down else -1.0) * (-1.0 if steer_left else 1.0),
        )

    def control(self, steer: float, throttle: float) -> None:
        self.steer_target = min(max(steer, -1.0), 1.0) * self.max_angle
        self.throttle = min(max(throttle, -1.0), 1.0)

    def apply_forces(self, dt: float, on_road: object = None) -> None:
        """Steer toward the target, change the speed by the pedal, set this step's velocities."""
        self.steer_toward_target(dt)
        if self.throttle >= 0:
            self.velocity += self.throttle * self.max_acceleration * dt
        else:
            self.velocity += self.throttle * self.max_deceleration * dt
        self.velocity = min(max(self.velocity, 0.0), self.max_velocity)
        turn_rate = self.turn_sign * self.velocity * math.tan(self.steer) / self.wheelbase
        half_turn = turn_rate * dt / 2  # [rad] aim along the chord of this step's arc
        chord = math.sin(half_turn) / half_turn if half_turn else 1.0
        direction = self.body.angle + half_turn
        speed = self.velocity * chord
        self.body.velocity = (speed * math.cos(direction), speed * math.sin(direction))
        self.body.angular_velocity = turn_rate

    def stop(self) -> None:
        """A crash: the car stands still."""
        self.velocity = 0.0
        self.body.velocity, self.body.angular_velocity = (0.0, 0.0), 0.0

    def state(self) -> CarState:
        """A copy of the car's state for sensors and pictures."""
        vx, vy = self.body.velocity
        pose = self.pose
        return CarState(
            model="kinematic_throttle",
            pose=pose,
            velocity=(vx, vy),
            speed=self.speed,
            yaw_rate=self.body.angular_velocity,
            steer=self.steer,
            front_axle=self.front_axle,
            rear_axle=self.rear_axle,
            footprint=self.footprint,
            hull_angle=pose[2],
        )
