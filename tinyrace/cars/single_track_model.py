"""The single-track vehicle model (CommonRoad's ST model, as F1TENTH's gym uses it): pure math.

No physics engine here: the derivatives, their input limits, an RK4 step, F1TENTH's two
controllers and the parameter presets, on plain floats (a 7-float state is cheaper as a
Python tuple than as a numpy array). ``tinyrace/cars/single_track.py`` drives a pymunk body
with it.

State (7): ``x, y`` [m] the centre of gravity; ``delta`` [rad] front-wheel angle (+ turns
toward growing yaw, i.e. left with y up); ``v`` [m/s] speed; ``psi`` [rad] yaw; ``psi_dot``
[rad/s] yaw rate; ``beta`` [rad] slip angle at the centre of gravity.
Inputs (2): steering velocity [rad/s], longitudinal acceleration [m/s^2].

The derivatives follow CommonRoad's ``vehicle_dynamics_st`` (commonroad-vehicle-models 3.0,
"CommonRoad: Vehicle Models", Althoff and Würsching 2020): above ``kinematic_below`` the
linear-tyre single-track model moves the car; below it, reversing included, the kinematic
single-track model about the centre of gravity (``vehicle_dynamics_ks_cog``), with the yaw
rate and slip derivatives of that model. CommonRoad goes kinematic only for |v| below the
switch speed, but its tyre equations hold for forward motion only: their 1/v terms turn
the yaw and slip damping into growth when v < 0 (a reversing car spun up and overflowed in a
few steps), so tinyrace reverses with the kinematic model, whose motion is defined at
every speed. The inputs are limited first: the steering velocity to its range and to
0 at full lock (pushing further), the acceleration to +-``a_max``, to ``a_max * v_switch / v``
above ``v_switch`` (the engine's power) and to 0 at ``v_min``/``v_max`` (pushing further).
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable
from dataclasses import dataclass

G = 9.81  # [m/s^2] gravity, as CommonRoad and F1TENTH take it
# A tyre's lateral force is held at this many times its friction limit (mu times its load):
# far beyond what a tyre gives, so driving within the tyres' grip (and well past it) is
# CommonRoad's linear-tyre model, while the runaway of that model stays bounded (see
# ``tyre_derivatives``).
RUNAWAY = 2.0

State = tuple[float, float, float, float, float, float, float]  # see the module's doc
Inputs = tuple[float, float]  # (steering velocity [rad/s], acceleration [m/s^2])


@dataclass(frozen=True)
class VehicleParameters:
    """One vehicle's parameters (CommonRoad's names in brackets)."""

    mu: float  # tyre-road friction coefficient [p_dy1]
    c_sf: float  # [1/rad] front cornering stiffness coefficient [-p_ky1 / p_dy1]
    c_sr: float  # [1/rad] rear cornering stiffness coefficient
    lf: float  # [m] centre of gravity to front axle [a]
    lr: float  # [m] centre of gravity to rear axle [b]
    h: float  # [m] centre of gravity height [h_s]
    m: float  # [kg] mass
    i_z: float  # [kg m^2] yaw moment of inertia
    steer_min: float  # [rad] steering angle limits [steering.min/max]
    steer_max: float
    steer_rate_min: float  # [rad/s] steering velocity limits [steering.v_min/v_max]
    steer_rate_max: float
    v_switch: float  # [m/s] above it the acceleration falls as a_max * v_switch / v
    a_max: float  # [m/s^2] largest acceleration (and deceleration)
    v_min: float  # [m/s] speed limits (negative: reversing)
    v_max: float
    length: float  # [m] of the body
    width: float  # [m] of the body
    kinematic_below: float = 0.1  # [m/s] |v| under which the kinematic model moves the car

    @property
    def wheelbase(self) -> float:
        """[m] rear to front axle."""
        return self.lf + self.lr


def _commonroad(
    a: float, b: float, h_s: float, m: float, i_z: float, lock: float, speeds: tuple[float, ...]
) -> VehicleParameters:
    """A CommonRoad vehicle: their tyres (p_dy1 1.0489, p_ky1 -21.92), steering velocity
    +-0.4 rad/s and a_max 11.5 m/s^2; ``speeds`` (v_switch, v_min, v_max, length, width)."""
    mu, c_s = 1.0489, 21.92 / 1.0489
    v_switch, v_min, v_max, length, width = speeds
    return VehicleParameters(
        mu, c_s, c_s, a, b, h_s, m, i_z, -lock, lock, -0.4, 0.4, v_switch, 11.5, v_min, v_max,
        length, width,
    )  # fmt: skip


# fmt: off
PRESETS: dict[str, VehicleParameters] = {
    # F1TENTH's gym defaults (f110_env.py): a 1/10 scale car, kinematic below 0.5 m/s as there
    "f1tenth": VehicleParameters(
        mu=1.0489, c_sf=4.718, c_sr=5.4562, lf=0.15875, lr=0.17145, h=0.074, m=3.74,
        i_z=0.04712, steer_min=-0.4189, steer_max=0.4189, steer_rate_min=-3.2,
        steer_rate_max=3.2, v_switch=7.319, a_max=9.51, v_min=-5.0, v_max=20.0, length=0.58,
        width=0.31, kinematic_below=0.5,
    ),
    # CommonRoad's published vehicles (parameters_vehicle1..3 of commonroad-vehicle-models)
    "vehicle1": _commonroad(  # Ford Escort
        0.88392, 1.50876, 0.59436, 1225.8878467253344, 1538.8533713561394, 0.91,
        (4.755, -13.9, 45.8, 4.298, 1.674),
    ),
    "vehicle2": _commonroad(  # BMW 320i
        1.1561957064, 1.4227170936, 0.61373004, 1093.2952334674046, 1791.5995300122856, 1.066,
        (7.319, -13.9, 50.8, 4.508, 1.61),
    ),
    "vehicle3": _commonroad(  # VW Vanagon
        1.1507916024, 1.3211363976000001, 0.804490644, 1478.8979637767998, 2473.1176915564442,
        1.023, (7.824, -11.2, 41.7, 4.569, 1.844),
    ),
}
# fmt: on


def limit_steering_rate(delta: float, rate: float, p: VehicleParameters) -> float:
    """[rad/s] the steering velocity the car can give at wheel angle ``delta``."""
    if (delta <= p.steer_min and rate <= 0) or (delta >= p.steer_max and rate >= 0):
        return 0.0
    return min(max(rate, p.steer_rate_min), p.steer_rate_max)


def limit_acceleration(v: float, accel: float, p: VehicleParameters) -> float:
    """[m/s^2] the acceleration the car can give at speed ``v`` (the ``v_switch`` rule)."""
    top = p.a_max * p.v_switch / v if v > p.v_switch else p.a_max
    if (v <= p.v_min and accel <= 0) or (v >= p.v_max and accel >= 0):
        return 0.0
    return min(max(accel, -p.a_max), top)


def derivatives(x: State, inputs: tuple[float, float], p: VehicleParameters) -> State:
    """d(state)/dt at state ``x`` under (steering velocity, acceleration), limited."""
    v = x[3]
    sv = limit_steering_rate(x[2], inputs[0], p)
    acc = limit_acceleration(v, inputs[1], p)
    if v < p.kinematic_below:  # slow, stopped or reversing (see the module's doc)
        return _kinematic(x, sv, acc, p)
    return tyre_derivatives(x, sv, acc, p)


def tyre_derivatives(
    x: State, sv: float, acc: float, p: VehicleParameters, guard: bool = True
) -> State:
    """The linear-tyre single-track model under limited inputs (valid for v > 0 only),
    written with each axle's lateral force (CommonRoad's equations rearranged): load
    ``m (g lr - a h) / l`` in front (``lf`` and ``+`` behind), slip angle ``delta - beta -
    lf psi_dot / v`` in front and ``lr psi_dot / v - beta`` behind, force ``mu C_S load
    slip``. A linear tyre's force grows with its slip without bound: a car braking hard at
    speed with its wheels turned oversteers, spins up and its state overflows (random
    actions did this within a second). With ``guard`` a force stops at ``RUNAWAY`` times the
    friction limit, against the wheel's sliding, which bounds the spin; CommonRoad's and
    f1tenth_gym's model (``guard`` False) is left below it."""
    delta, v, psi, psi_dot, beta = x[2], x[3], x[4], x[5], x[6]
    lf, lr = p.lf, p.lr
    wheelbase = lf + lr
    grip_front = p.mu * p.m * (G * lr - acc * p.h) / wheelbase  # [N] mu times the load
    grip_rear = p.mu * p.m * (G * lf + acc * p.h) / wheelbase
    front = grip_front * p.c_sf * (delta - beta - lf * psi_dot / v)  # [N] lateral forces
    rear = grip_rear * p.c_sr * (lr * psi_dot / v - beta)
    if guard and abs(front) > RUNAWAY * grip_front:  # against the wheel's lateral motion
        slide = v * math.sin(delta - beta) - lf * psi_dot * math.cos(delta)
        front = math.copysign(RUNAWAY * grip_front, slide)
    if guard and abs(rear) > RUNAWAY * grip_rear:
        rear = math.copysign(RUNAWAY * grip_rear, lr * psi_dot - v * math.sin(beta))
    return (
        v * math.cos(beta + psi),
        v * math.sin(beta + psi),
        sv,
        acc,
        psi_dot,
        (lf * front - lr * rear) / p.i_z,
        (front + rear) / (p.m * v) - psi_dot,
    )


def _kinematic(x: State, sv: float, acc: float, p: VehicleParameters) -> State:
    """The kinematic single-track model about the centre of gravity, with CommonRoad's
    yaw-acceleration and slip-rate terms (so that the dynamic model takes over smoothly)."""
    delta, v, psi, beta = x[2], x[3], x[4], x[6]
    wheelbase = p.lf + p.lr
    tan_delta = math.tan(delta)
    cos2 = math.cos(delta) ** 2
    slip = math.atan(tan_delta * p.lr / wheelbase)  # the kinematic model's slip angle
    d_beta = (p.lr * sv) / (wheelbase * cos2 * (1 + (tan_delta**2 * p.lr / wheelbase) ** 2))
    dd_psi = (
        1
        / wheelbase
        * (
            acc * math.cos(beta) * tan_delta
            - v * math.sin(beta) * d_beta * tan_delta
            + v * math.cos(beta) * sv / cos2
        )
    )
    return (
        v * math.cos(slip + psi),
        v * math.sin(slip + psi),
        sv,
        acc,
        v * math.cos(slip) * tan_delta / wheelbase,
        dd_psi,
        d_beta,
    )


def _moved(x: State, k: State, h: float) -> State:
    return (
        x[0] + h * k[0], x[1] + h * k[1], x[2] + h * k[2], x[3] + h * k[3], x[4] + h * k[4],
        x[5] + h * k[5], x[6] + h * k[6],
    )  # fmt: skip


Derivatives = Callable[[State, Inputs, "VehicleParameters"], State]


def rk4_step(
    x: State, inputs: Inputs, p: VehicleParameters, dt: float, f: Derivatives | None = None
) -> State:
    """The state ``dt`` [s] later, the inputs held (classic fourth-order Runge-Kutta) on the
    derivatives ``f`` (None: ``derivatives``)."""
    f = derivatives if f is None else f
    k1 = f(x, inputs, p)
    k2 = f(_moved(x, k1, dt / 2), inputs, p)
    k3 = f(_moved(x, k2, dt / 2), inputs, p)
    k4 = f(_moved(x, k3, dt), inputs, p)
    sixth = dt / 6
    return (
        x[0] + sixth * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
        x[1] + sixth * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]),
        x[2] + sixth * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2]),
        x[3] + sixth * (k1[3] + 2 * k2[3] + 2 * k3[3] + k4[3]),
        x[4] + sixth * (k1[4] + 2 * k2[4] + 2 * k3[4] + k4[4]),
        x[5] + sixth * (k1[5] + 2 * k2[5] + 2 * k3[5] + k4[5]),
        x[6] + sixth * (k1[6] + 2 * k2[6] + 2 * k3[6] + k4[6]),
    )


def steering_controller(target: float, delta: float, p: VehicleParameters) -> float:
    """F1TENTH's steering controller: [rad/s] full steering velocity toward ``target`` [rad]
    (bang-bang, dead band 1e-4 rad). Held over a whole step it overshoots by up to a step's
    worth of turning and chatters about a held target: tinyrace's cars use
    ``settling_steering``; ``car.compat: f1tenth_gym`` uses this one."""
    error = target - delta
    if abs(error) <= 1e-4:
        return 0.0
    return p.steer_rate_max if error > 0 else p.steer_rate_min


def settling_steering(target: float, delta: float, p: VehicleParameters, h: float) -> float:
    """[rad/s] full steering velocity toward ``target`` [rad], but no faster than reaching it
    in ``h`` [s]: held over an integration step of ``h`` the wheels land on the target
    (the steering angle's derivative is this rate alone) and stay there."""
    return min(max((target - delta) / h, p.steer_rate_min), p.steer_rate_max)


def speed_controller(target: float, v: float, p: VehicleParameters) -> float:
    """F1TENTH's speed controller: [m/s^2] proportional to the speed error, its gain 10 a_max
    per the speed range's end moving forward, 2 a_max per it reversing."""
    error = target - v
    gain = 10.0 if v > 0 else 2.0
    reach = p.v_max if error > 0 else -p.v_min  # [m/s] the range's end on the error's side
    return gain * p.a_max / reach * error


def _substep(x: State, inputs: tuple[float, float], p: VehicleParameters, h: float) -> State:
    """One RK4 step of ``h``; the steering angle and the speed put back inside their limits
    (a step that reaches a limit part way overshoots it by up to a step's worth of motion)."""
    x = rk4_step(x, inputs, p, h)
    delta = min(max(x[2], p.steer_min), p.steer_max)
    v = min(max(x[3], p.v_min), p.v_max)
    beta = x[6] if -math.pi <= x[6] <= math.pi else math.remainder(x[6], math.tau)  # a spin
    if delta != x[2] or v != x[3] or beta != x[6]:
        x = (x[0], x[1], delta, v, x[4], x[5], beta)
    return x


def step(
    x: State, inputs: tuple[float, float], p: VehicleParameters, dt: float, substeps: int = 1
) -> State:
    """The state ``dt`` [s] later: ``substeps`` RK4 steps, the inputs (steering velocity,
    acceleration) held, each step's end kept inside the limits."""
    h = dt / substeps
    for _ in range(substeps):
        x = _substep(x, inputs, p, h)
    return x


def step_toward(
    x: State, target: tuple[float, float], p: VehicleParameters, dt: float, substeps: int = 1
) -> State:
    """The state ``dt`` [s] later under a target (steering angle [rad], speed [m/s]): before
    each of the ``substeps`` RK4 steps the controllers (``settling_steering``,
    ``speed_controller``) turn the target into the step's inputs, so a held target is reached
    and held at any sim rate."""
    h = dt / substeps
    angle, speed = target
    for _ in range(substeps):
        inputs = (settling_steering(angle, x[2], p, h), speed_controller(speed, x[3], p))
        x = _substep(x, inputs, p, h)
    return x


def stiffness(p: VehicleParameters, v: float) -> float:
    """[1/s] the largest |eigenvalue| of the yaw-rate and slip dynamics at speed ``v`` [m/s]
    (straight ahead, coasting): they grow as 1/v, which limits the RK4 step at low speed."""
    wheelbase = p.lf + p.lr
    front, rear = p.c_sf * G * p.lr, p.c_sr * G * p.lf
    yaw = p.mu * p.m / (p.i_z * wheelbase)
    a = -yaw * (p.lf**2 * front + p.lr**2 * rear) / v
    b = yaw * (p.lr * rear - p.lf * front)
    c = p.mu / (v**2 * wheelbase) * (rear * p.lr - front * p.lf) - 1
    d = -p.mu / (v * wheelbase) * (rear + front)
    half_trace, det = (a + d) / 2, a * d - b * c
    root = cmath.sqrt(half_trace**2 - det)
    return max(abs(half_trace + root), abs(half_trace - root))


STABLE_STEP = 2.0  # |eigenvalue| * step kept under this (RK4 is stable to about 2.78)


def substeps_for(p: VehicleParameters, dt: float, v: float | None = None) -> int:
    """RK4 steps per ``dt`` [s] that keep the yaw and slip motion stable over a step that
    starts at speed ``v`` [m/s] (the speed may fall by ``a_max * dt`` in it); None: at any
    speed (the stiffest, just above the switch to the kinematic model)."""
    slowest = p.kinematic_below
    if v is not None:
        slowest = max(abs(v) - p.a_max * dt, slowest)
    return max(1, math.ceil(stiffness(p, slowest) * dt / STABLE_STEP))
