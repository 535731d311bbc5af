"""The single-track car (``car.model: single_track``) against its reference: CommonRoad's
``vehicle_dynamics_st`` (commonroad-vehicle-models) for the derivatives and parameters, scipy's
``solve_ivp`` for the RK4 rollouts; and in the env: walls stop it, the centreline driver laps."""

from __future__ import annotations

import itertools
import math

import gymnasium as gym
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vehiclemodels.parameters_vehicle1 import parameters_vehicle1
from vehiclemodels.parameters_vehicle2 import parameters_vehicle2
from vehiclemodels.parameters_vehicle3 import parameters_vehicle3
from vehiclemodels.vehicle_dynamics_st import vehicle_dynamics_st

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.cars import single_track_model as st
from tinyrace.drivers.centerline import CenterlineDriver
from tinyrace.examples import TRACKS_DIR

REFERENCE = {"vehicle1": parameters_vehicle1, "vehicle2": parameters_vehicle2}
REFERENCE["vehicle3"] = parameters_vehicle3
G = 9.81


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_presets_are_commonroads_vehicles(name):
    ref, ours = REFERENCE[name](), st.PRESETS[name]
    assert (ours.lf, ours.lr, ours.h, ours.m, ours.i_z) == (ref.a, ref.b, ref.h_s, ref.m, ref.I_z)
    assert ours.mu == ref.tire.p_dy1
    assert ours.c_sf == ours.c_sr == -ref.tire.p_ky1 / ref.tire.p_dy1
    steering, longitudinal = ref.steering, ref.longitudinal
    assert (ours.steer_min, ours.steer_max) == (steering.min, steering.max)
    assert (ours.steer_rate_min, ours.steer_rate_max) == (steering.v_min, steering.v_max)
    assert (ours.v_min, ours.v_max) == (longitudinal.v_min, longitudinal.v_max)
    assert (ours.v_switch, ours.a_max) == (longitudinal.v_switch, longitudinal.a_max)
    assert (ours.length, ours.width, ours.kinematic_below) == (ref.l, ref.w, 0.1)


# low and high speeds (both sides of the 0.1 m/s switch, reversing), both steering signs up to
# and past the lock, slip and yaw rate of both signs, inputs inside and beyond their limits
SPEEDS = (-3.0, -0.05, 0.0, 0.09, 0.5, 5.0, 20.0, 60.0)
STEERS = (-1.1, -0.3, 0.0, 0.2, 1.066)
SLIPS = (-0.2, 0.0, 0.1)
YAW_RATES = (-1.0, 0.0, 0.7)
STEER_RATES = (-1.0, 0.0, 0.3)
ACCELS = (-15.0, -2.0, 0.0, 3.0, 15.0)


def commonroad(x: tuple[float, ...], inputs: tuple[float, float], ref: object) -> np.ndarray:
    """CommonRoad's derivatives; reversing beyond its switch speed, those of its kinematic
    branch, which tinyrace takes there (its tyre equations hold forward only): that branch
    is affine in v (its acceleration limit the same for every v in 0 > v > v_min), so its
    values at -0.05 and 0.05 m/s, inside the switch, give it at any reversing speed."""
    v = x[3]
    if v > -0.1:
        return np.array(vehicle_dynamics_st(list(x), list(inputs), ref), float)
    at = [
        np.array(vehicle_dynamics_st([*x[:3], s, *x[4:]], list(inputs), ref)) for s in (-0.05, 0.05)
    ]
    return at[0] + (at[1] - at[0]) / 0.1 * (v + 0.05)


def within_grip(x: tuple[float, ...], p: st.VehicleParameters) -> bool:
    """Whether both tyres of the single-track model are inside the runaway guard
    (|C_S slip angle| <= RUNAWAY), where tinyrace's tyres are CommonRoad's linear ones."""
    delta, v, yaw_rate, beta = x[2], x[3], x[5], x[6]
    if v < p.kinematic_below:
        return True
    front = delta - beta - p.lf * yaw_rate / v
    rear = p.lr * yaw_rate / v - beta
    return max(abs(p.c_sf * front), abs(p.c_sr * rear)) <= st.RUNAWAY


def derivative_error(name: str) -> tuple[float, int]:
    """The largest difference (relative beyond 1) and how many states were compared."""
    ref, ours = REFERENCE[name](), st.PRESETS[name]
    worst, compared = 0.0, 0
    grid = itertools.product(SPEEDS, STEERS, SLIPS, YAW_RATES, STEER_RATES, ACCELS)
    for v, delta, beta, yaw_rate, rate, accel in grid:
        x = (1.0, -2.0, delta, v, 0.4, yaw_rate, beta)
        if not within_grip(x, ours):
            continue
        expected = commonroad(x, (rate, accel), ref)
        got = np.array(st.derivatives(x, (rate, accel), ours))
        scale = np.maximum(1.0, np.abs(expected))
        worst = max(worst, float(np.max(np.abs(got - expected) / scale)))
        compared += 1
    return worst, compared


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_derivatives_equal_commonroads(name):
    worst, compared = derivative_error(name)
    assert worst <= 1e-12 and compared >= 1500


@pytest.mark.parametrize("name", sorted(st.PRESETS))
def test_the_runaway_guard_holds_the_tyre_forces(name):
    """Past |C_S slip| = RUNAWAY a tyre's lateral force stays at RUNAWAY times mu times its
    load, against the wheel's sliding: the lateral acceleration never exceeds RUNAWAY mu g
    (the linear tyre's grows with the slip), and a spinning car's yaw rate is braked."""
    p = st.PRESETS[name]
    grip = st.RUNAWAY * p.mu * G
    for v, delta, beta, yaw_rate in itertools.product(
        (1.0, 8.0, 20.0), (-0.4, 0.0, 0.4), (-3.0, -0.6, 0.0, 0.5, 2.5), (-20.0, -2.0, 0.0, 6.0)
    ):
        x = (0.0, 0.0, delta, v, 0.0, yaw_rate, beta)
        d = st.derivatives(x, (0.0, 0.0), p)
        lateral = v * (d[6] + d[4])  # [m/s^2] v times the velocity direction's turn rate
        assert abs(lateral) <= grip * (1 + 1e-12)
        if abs(yaw_rate) >= 6.0 and abs(delta) < 1e-9 and beta == 0.0:  # spinning, no slip
            assert d[5] * yaw_rate < 0


CASES = {  # name: (start state, [steering velocity rad/s, acceleration m/s^2])
    "rolling from rest": ((0, 0, 0, 0, 0, 0, 0), (0.0, 0.0)),
    "braking from rest": ((0, 0, 0, 0, 0, 0, 0), (0.0, -0.7 * G)),
    "accelerating and steering from rest": ((0, 0, 0, 0, 0, 0, 0), (0.15, 0.63 * G)),
    "steering left from rest": ((0, 0, 0, 0, 0, 0, 0), (0.15, 0.0)),
    "steering right to the lock, accelerating": ((0, 0, 0, 0, 0, 0, 0), (-3.0, 3.0)),
    "rolling at speed": ((0, 0, 0, 15, 0, 0, 0), (0.0, 0.0)),
    "braking at speed": ((0, 0, 0, 15, 0, 0, 0), (0.0, -0.7 * G)),
    "steering at speed": ((0, 0, 0, 15, 0, 0, 0), (0.15, 0.0)),
    "accelerating and steering at speed": ((0, 0, 0.05, 5, 0, 0.1, 0.01), (-0.1, 0.63 * G)),
}


def rollout_error(name: str, case: str, dt: float) -> float:
    """Max |RK4 at the sim's step - solve_ivp (rtol = atol = 1e-10)| after 1 s."""
    p = st.PRESETS[name]
    start, inputs = CASES[case]
    x: st.State = tuple(float(v) for v in start)  # type: ignore[assignment]
    fine = solve_ivp(
        lambda t, y: st.derivatives(tuple(y), inputs, p),  # type: ignore[arg-type]
        (0.0, 1.0),
        np.array(x),
        rtol=1e-10,
        atol=1e-10,
    )
    for _ in range(round(1.0 / dt)):  # as the car steps: sub-steps by the speed
        x = st.step(x, inputs, p, dt, st.substeps_for(p, dt, x[3]))
    return float(np.max(np.abs(np.array(x) - fine.y[:, -1])))


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("name", sorted(st.PRESETS))
def test_rollouts_follow_a_fine_ode_solution(name, case):
    for dt in (0.01, 0.02):  # F1TENTH's step and the metre tracks' default (50 fps)
        assert rollout_error(name, case, dt) < 1e-2


def test_one_rk4_step_without_substeps_goes_wrong_at_the_switch():
    """The sub-steps matter: a CommonRoad car just above 0.1 m/s is stiff (its yaw and slip
    modes decay at ~2000/s), beyond one RK4 step of 0.02 s: one step per sim step swings the
    yaw rate far from the sub-stepped one (which follows a fine ODE solution, above); the
    tyres' friction limit keeps it finite."""
    p = st.PRESETS["vehicle2"]
    assert st.stiffness(p, p.kinematic_below) * 0.02 > 2.8
    one: st.State = (0, 0, 0, 0, 0, 0, 0)
    many = one
    worst = 0.0
    for _ in range(50):
        one = st.step(one, (0.15, 0.63 * G), p, 0.02, 1)
        many = st.step(many, (0.15, 0.63 * G), p, 0.02, st.substeps_for(p, 0.02, many[3]))
        worst = max(worst, abs(one[5] - many[5]))
    assert worst > 0.02
    assert all(math.isfinite(v) for v in one)


def test_f1tenth_controllers():
    p = st.PRESETS["f1tenth"]
    assert st.steering_controller(0.3, 0.0, p) == 3.2
    assert st.steering_controller(-0.3, 0.0, p) == -3.2
    assert st.steering_controller(0.10005, 0.1, p) == 0.0  # inside the 1e-4 rad dead band
    assert st.speed_controller(10.0, 5.0, p) == pytest.approx(10 * 9.51 / 20.0 * 5)
    assert st.speed_controller(0.0, 5.0, p) == pytest.approx(10 * 9.51 / 5.0 * -5)
    assert st.speed_controller(-1.0, 0.0, p) == pytest.approx(2 * 9.51 / 5.0 * -1)


def test_the_v_switch_rule_limits_acceleration():
    p = st.PRESETS["f1tenth"]
    assert st.limit_acceleration(2.0, 50.0, p) == p.a_max
    assert st.limit_acceleration(14.638, 50.0, p) == pytest.approx(p.a_max / 2)
    assert st.limit_acceleration(20.0, 1.0, p) == 0.0  # at v_max
    assert st.limit_steering_rate(0.4189, 1.0, p) == 0.0  # at the lock


def make(track: str, **car: object) -> gym.Env:
    config = {"model": "single_track", **car}
    return gym.make("tinyrace/TinyRace-v0", environment=str(TRACKS_DIR / track), car=config)


def test_actions_are_f1tenths_or_the_models_inputs():
    env = make("f1tenth_loop")
    space = env.action_space
    assert np.allclose(space.low, [-0.4189, -5.0]) and np.allclose(space.high, [0.4189, 20.0])
    raw = make("f1tenth_loop", actions="raw").action_space
    assert np.allclose(raw.low, [-3.2, -9.51]) and np.allclose(raw.high, [3.2, 9.51])
    env.close()


def test_the_car_follows_the_model_in_the_world():
    """Driving straight on: the body lands where the model's integration puts it."""
    env = make("f1tenth_loop", actions="raw", substeps=4)
    _, info = env.reset(seed=0)
    x, y, psi = info["pose"]
    state: st.State = (x, y, 0.0, 0.0, psi, 0.0, 0.0)
    dt = env.unwrapped.dt
    for _ in range(20):
        _, _, _, _, info = env.step(np.array([0.0, 2.0], np.float32))
        state = st.step(state, (0.0, 2.0), st.PRESETS["f1tenth"], dt, 4)
    assert np.allclose(info["pose"], (state[0], state[1], state[4]), atol=1e-9)
    assert info["speed"] == pytest.approx(state[3])
    env.close()


def test_a_wall_stops_it():
    env = make("f1tenth_loop")
    env.reset(seed=0)
    for _ in range(300):  # straight ahead at 5 m/s: the corridor bends away
        _, _, _, _, info = env.step(np.array([0.0, 5.0], np.float32))
        if info["walls_hit"]:
            break
    assert info["walls_hit"] > 0
    assert info["speed"] == 0.0
    env.close()


LAPS = {  # (track, actions): (preset, steps within which a lap completes)
    ("f1tenth_loop", "continuous"): ("f1tenth", 700),
    ("f1tenth_loop", "raw"): ("f1tenth", 700),
    ("autocross", "continuous"): ("vehicle2", 1500),
    ("circuit", "continuous"): ("vehicle1", 5000),
}


@pytest.mark.parametrize(("track", "actions"), sorted(LAPS))
def test_the_centerline_driver_laps_with_the_single_track_car(track, actions):
    preset, limit = LAPS[track, actions]
    env = make(track, preset=preset, actions=actions)
    driver = CenterlineDriver()
    observation, info = env.reset(seed=0)
    driver.reset(env)
    for _ in range(limit):
        action = driver.act(observation, info)
        observation, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    assert info.get("lap_finished") is True
    assert info["walls_hit"] == 0 and info["cones_hit"] == 0
    env.close()


class Keys:
    """pygame's key constants, as ``tinyrace.play`` reads them."""

    K_RIGHT, K_LEFT, K_UP, K_DOWN = range(4)


@pytest.mark.parametrize("actions", ["continuous", "raw"])
def test_the_keyboard_steers_left_with_the_left_arrow(actions):
    from tinyrace.play import _action

    env = make("f1tenth_loop", actions=actions).unwrapped
    _, info = env.reset(seed=0)
    heading = info["pose"][2]
    for _ in range(10):  # left and up
        _, _, _, _, info = env.step(_action(env, [0, 1, 1, 0], Keys))
    assert info["pose"][2] > heading + 0.05 and info["speed"] > 0.5
    env.close()


def test_cones_count_it_as_they_count_the_other_cars():
    """Straight ahead from autocross's start, the car meets a cone: it is knocked and counted
    (cone_hit_ends_episode is off there), as for the kinematic car with throttle."""
    env = make("autocross")
    env.reset(seed=0)
    for _ in range(200):
        _, _, terminated, truncated, info = env.step(np.array([0.0, 5.0], np.float32))
        if info["cones_hit"] or terminated or truncated:
            break
    assert info["cones_hit"] == 1
    env.close()


@pytest.mark.parametrize(
    ("car", "mount", "axle"),
    [
        ({"model": "single_track", "preset": "f1tenth"}, None, "pose"),  # F1TENTH's place
        ({"model": "single_track", "preset": "vehicle2", "compat": "f1tenth_gym"}, None, "pose"),
        ({"model": "single_track", "preset": "vehicle2"}, None, "front_axle"),
        ({"model": "kinematic_throttle"}, None, "front_axle"),
        ({"model": "single_track", "preset": "f1tenth"}, "front_axle", "front_axle"),
        ({"model": "single_track", "preset": "f1tenth"}, "rear_axle", "rear_axle"),
    ],
)
def test_the_f1tenth_preset_puts_the_lidar_where_f1tenth_has_it(car, mount, axle):
    """f1tenth_gym scans from its car's pose (lidar_dist 0 m ahead of it by default): the
    f1tenth preset's lidar (and f1tenth_gym's car's) starts there unless the config names a
    mount."""
    lidar = {"id": "lidar", "type": "lidar", "beams": 8, **({"mount": mount} if mount else {})}
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment=str(TRACKS_DIR / "circuit"),  # room for every car
        car=car,
        sensors=[lidar],
    )
    env.reset(seed=0)
    raw = env.unwrapped
    snapshot = raw.snapshot()
    sensor = raw.sensors[-1]
    where = snapshot.car.pose[:2] if axle == "pose" else getattr(snapshot.car, axle)
    assert where != pytest.approx(snapshot.car.front_axle) or axle == "front_axle"
    assert sensor.origin(snapshot, raw.layout) == pytest.approx(where)
