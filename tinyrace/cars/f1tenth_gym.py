"""f1tenth_gym's car on request (``car.compat: f1tenth_gym``): its car step by step, for
results to be ported between the two.

What f1tenth_gym (main, 4fdb9c7: ``RaceCar.update_pose`` and ``vehicle_dynamics_st``) does
and tinyrace's own single-track car does otherwise:

- a steering buffer: the angle commanded is applied two steps later (0 for the first two
  steps of an episode);
- its controllers once per step, the steering one bang-bang at full steering velocity with
  a 1e-4 rad dead band (``single_track_model.steering_controller``: it chatters about a held
  angle), then one RK4 step of the whole step (0.01 s: its sim rate, 100 Hz), the steering
  angle and speed left where the step puts them;
- below 0.5 m/s the kinematic single-track model about the rear axle (the pose moves along
  the heading), its yaw rate's derivative that of the kinematic yaw rate and the slip
  angle's rate held at 0; above, the same linear-tyre equations as tinyrace's.

One departure: f1tenth_gym moves a car reversing faster than 0.5 m/s with the tyre
equations, whose 1/v terms make the yaw motion grow without bound in reverse (its state
overflows within a few steps); here every speed below 0.5 m/s, reversing included, takes the
low-speed model. The lidar scans from the pose (f1tenth_gym's ``lidar_dist`` 0). The
reference trajectories of ``tests/data/f1tenth_gym`` were recorded from f1tenth_gym's own
code (``tests/data/f1tenth_gym/record.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from tinyrace.cars import single_track_model as model
from tinyrace.cars.single_track_model import Inputs, State, VehicleParameters
from tinyrace.config.schema import F1TENTH_GYM_RATE

NAME = "f1tenth_gym"  # the ``car.compat`` value
SIM_RATE = F1TENTH_GYM_RATE  # [Hz] f1tenth_gym's default time step, 0.01 s
STEER_DELAY = 2  # [steps] f1tenth_gym's steer_buffer_size
LOW_SPEED = 0.5  # [m/s] below it, the kinematic model about the rear axle


def derivatives(x: State, inputs: Inputs, p: VehicleParameters) -> State:
    """d(state)/dt as f1tenth_gym's ``vehicle_dynamics_st`` (inputs limited as there)."""
    v = x[3]
    sv = model.limit_steering_rate(x[2], inputs[0], p)
    acc = model.limit_acceleration(v, inputs[1], p)
    if v < LOW_SPEED:  # |v| < 0.5 there; reversing faster too here (see the module's doc)
        return _rear_axle(x, sv, acc, p)
    return model.tyre_derivatives(x, sv, acc, p, guard=False)


def _rear_axle(x: State, sv: float, acc: float, p: VehicleParameters) -> State:
    """The kinematic single-track model about the rear axle, its slip rate 0."""
    delta, v, psi = x[2], x[3], x[4]
    wheelbase = p.lf + p.lr
    tan_delta = math.tan(delta)
    return (
        v * math.cos(psi),
        v * math.sin(psi),
        sv,
        acc,
        v / wheelbase * tan_delta,
        acc / wheelbase * tan_delta + v / (wheelbase * math.cos(delta) ** 2) * sv,
        0.0,
    )


@dataclass
class F1tenthGymMotion:
    """One car's steering buffer and its step, as f1tenth_gym's ``RaceCar.update_pose``."""

    pending: list[float] = field(default_factory=list)  # commanded angles, oldest first

    def advance(
        self, x: State, action: tuple[float, float], p: VehicleParameters, dt: float
    ) -> State:
        """The state ``dt`` [s] later under ``action`` (steering angle [rad], speed [m/s])."""
        angle, speed = action
        steer = self.pending.pop(0) if len(self.pending) >= STEER_DELAY else 0.0
        self.pending.append(angle)
        inputs = (model.steering_controller(steer, x[2], p), model.speed_controller(speed, x[3], p))
        return model.rk4_step(x, inputs, p, dt, derivatives)
