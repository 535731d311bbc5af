"""The single-track car in a pymunk world: CommonRoad's single-track model (see
``single_track_model.py``) moves the car; pymunk carries its footprint.

The body's origin is the centre of gravity and ``body.angle`` the yaw (y up, headings
counter-clockwise: the metre tracks). Each step integrates the model from the body's pose,
then gives the body the velocities that take it to the integrated pose in one world step;
a wall the footprint meets puts the body back and ``stop`` halts the car, as for the
kinematic cars.

Actions (``car.actions``): ``continuous`` is F1TENTH's [steering angle rad, speed m/s],
turned into the model's inputs before every integration step (the steering at full rate up
to the angle and no further, the speed by F1TENTH's proportional controller), so a held
angle is reached and held at any sim rate; ``raw`` is the model's own [steering velocity
rad/s, acceleration m/s^2]. A positive angle turns left (toward growing headings).
``car.compat: f1tenth_gym`` steps f1tenth_gym's car instead (``f1tenth_gym.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymunk

from tinyrace.cars import single_track_model as model
from tinyrace.cars.collision import footprint_sensor
from tinyrace.cars.f1tenth_gym import F1tenthGymMotion
from tinyrace.cars.state import CarState


@dataclass
class SingleTrackCar:
    """A car moved by the single-track model; ``control(a, b)`` per ``mode``."""

    body: pymunk.Body
    params: model.VehicleParameters
    raw: bool  # actions are the model's inputs (else a target angle and speed)
    substeps: int | None  # RK4 steps per world step (None: enough for stability at the speed)
    delta: float = 0.0  # [rad] front-wheel angle, + left
    v: float = 0.0  # [m/s] speed
    yaw_rate: float = 0.0  # [rad/s]
    slip: float = 0.0  # [rad] slip angle at the centre of gravity
    action: tuple[float, float] = (0.0, 0.0)
    compat: F1tenthGymMotion | None = None  # f1tenth_gym's car step by step (car.compat)

    @classmethod
    def build(
        cls,
        space: pymunk.Space,
        pose: tuple[float, float, float],
        params: model.VehicleParameters,
        raw: bool = False,
        substeps: int | None = None,
        compat: str | None = None,
    ) -> SingleTrackCar:
        """A car standing at ``pose`` (centre of gravity x, y [m], yaw [rad]); ``compat``
        ``"f1tenth_gym"``: f1tenth_gym's car (continuous actions, one step per world step)."""
        body = pymunk.Body(1.0, math.inf)  # driven by its velocity (see KinematicCar)
        x, y, heading = pose
        body.position, body.angle = (x, y), heading
        overhang = max(params.length - params.wheelbase, 0.0) / 2  # [m] beyond each axle
        half = params.width / 2
        box = footprint_sensor(body, (-params.lr - overhang, -half), (params.lf + overhang, half))
        space.add(body, box)
        motion = F1tenthGymMotion() if compat == "f1tenth_gym" else None
        return cls(body, params, raw, substeps, compat=motion)

    def control(self, first: float, second: float) -> None:
        self.action = (first, second)

    def apply_forces(self, dt: float, on_road: object = None) -> None:
        """Integrate the model over ``dt`` from the body's pose; aim the body at the result."""
        body = self.body
        x, y = body.position
        psi = body.angle
        state = (x, y, self.delta, self.v, psi, self.yaw_rate, self.slip)
        if self.compat is not None:
            end = self.compat.advance(state, self.action, self.params, dt)
        elif self.raw:
            end = model.step(state, self.action, self.params, dt, self.steps_per(dt))
        else:
            end = model.step_toward(state, self.action, self.params, dt, self.steps_per(dt))
        _, _, self.delta, self.v, _, self.yaw_rate, self.slip = end
        body.velocity = ((end[0] - x) / dt, (end[1] - y) / dt)
        body.angular_velocity = (end[4] - psi) / dt

    def steps_per(self, dt: float) -> int:
        """RK4 steps in a world step of ``dt`` [s]: the knob's, or as many as the speed now
        needs (the yaw and slip motion stiffens as 1/v: many near the switch speed, one at
        speed)."""
        if self.substeps is not None:
            return self.substeps
        return model.substeps_for(self.params, dt, self.v)

    def stop(self) -> None:
        """A crash: the car stands still (its wheels keep their angle)."""
        self.v = self.yaw_rate = self.slip = 0.0
        self.body.velocity, self.body.angular_velocity = (0.0, 0.0), 0.0

    @property
    def pose(self) -> tuple[float, float, float]:
        x, y = self.body.position
        return x, y, self.body.angle

    @property
    def speed(self) -> float:
        return self.v

    @property
    def footprint(self) -> tuple[float, float]:
        """(wheelbase, width) [m]."""
        return self.params.wheelbase, self.params.width

    def _along(self, distance: float) -> tuple[float, float]:
        x, y = self.body.position
        heading = self.body.angle
        return x + distance * math.cos(heading), y + distance * math.sin(heading)

    @property
    def rear_axle(self) -> tuple[float, float]:
        return self._along(-self.params.lr)

    @property
    def front_axle(self) -> tuple[float, float]:
        return self._along(self.params.lf)

    def state(self) -> CarState:
        """A copy of the car's state for sensors and pictures."""
        vx, vy = self.body.velocity
        pose = self.pose
        return CarState(
            model="single_track",
            pose=pose,
            velocity=(vx, vy),
            speed=self.v,
            yaw_rate=self.yaw_rate,
            steer=self.delta,
            front_axle=self.front_axle,
            rear_axle=self.rear_axle,
            footprint=self.footprint,
            hull_angle=pose[2],
        )
