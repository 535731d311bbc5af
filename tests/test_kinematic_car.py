"""tinycarlo's kinematic bicycle, and CarRacing's dynamic car, on image tracks.

Conventions (tinycarlo 1.1's): image pixels, x right, y down; heading 0 along
+x, growing clockwise on screen; a positive steering action turns right.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from gymnasium import spaces
from synthetic import blank, make_env, straight, write_track

FULL_LOCK = math.radians(33.0)


def plane_env(tmp_path, spawn, car=None, fps=30, size=3000):
    config = {
        "sim": {"fps": fps},
        "car": car or {},
        "tracks": [{"image": "track.png", "spawns": [list(spawn)]}],
    }
    return make_env(write_track(tmp_path, blank(size, size), config))


def drive(env, actions):
    """Poses after each action (the reset pose first)."""
    _, info = env.reset(seed=0)
    poses = [info["pose"]]
    for action in actions:
        _, _, terminated, truncated, info = env.step(np.asarray(action, np.float32))
        assert not (terminated or truncated)
        poses.append(info["pose"])
    return np.array(poses)


def tinycarlo_step(pose, steer_deg, velocity, wheelbase, dt):
    """One step of tinycarlo 1.1's bicycle: an exact arc (or a line) at constant speed."""
    x, y, heading = pose
    if steer_deg == 0:
        return x + velocity * dt * math.cos(heading), y + velocity * dt * math.sin(heading), heading
    radius = wheelbase / math.tan(math.radians(steer_deg))
    turn = velocity / radius * dt
    # the centre of the turn lies ``radius`` to the car's right: (-sin a, cos a) on screen
    cx, cy = x - radius * math.sin(heading), y + radius * math.cos(heading)
    dx, dy = x - cx, y - cy
    cos_t, sin_t = math.cos(turn), math.sin(turn)
    return cx + cos_t * dx - sin_t * dy, cy + sin_t * dx + cos_t * dy, heading + turn


def test_action_space_is_one_normalised_steering_angle(tmp_path):
    env = plane_env(tmp_path, (500, 500, 0))
    assert env.action_space == spaces.Box(-1.0, 1.0, (1,), np.float32)


def test_measured_straight_run(tmp_path):
    """tinycarlo: from (700, 1460, 0.48) at 500 px/s and 30 fps, 30 steps end near (1143, 1691)."""
    env = plane_env(tmp_path, (700.0, 1460.0, 0.48), {"velocity": 500})
    poses = drive(env, [straight()] * 30)
    assert poses[0] == pytest.approx((700.0, 1460.0, 0.48))
    assert poses[-1][0] == pytest.approx(1143, abs=1)
    assert poses[-1][1] == pytest.approx(1691, abs=1)
    assert poses[-1][2] == pytest.approx(0.48)
    steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    np.testing.assert_allclose(steps, 500 / 30)  # constant speed [px/step]


@pytest.mark.parametrize("velocity, fps", [(500, 30), (250, 60)])
def test_speed_is_in_pixels_per_second(tmp_path, velocity, fps):
    env = plane_env(tmp_path, (500.0, 500.0, -1.0), {"velocity": velocity}, fps=fps)
    poses = drive(env, [straight()] * fps)  # one simulated second
    assert math.dist(poses[0][:2], poses[-1][:2]) == pytest.approx(velocity, rel=1e-9)


@pytest.mark.parametrize("steer, wheelbase", [(1.0, 160), (-1.0, 160), (1.0, 90)])
def test_full_lock_circle(tmp_path, steer, wheelbase):
    """A full circle at full lock has radius wheelbase / tan(33 deg), to the side steered."""
    radius = wheelbase / math.tan(FULL_LOCK)
    velocity, fps = 500.0, 30
    period = 2 * math.pi * radius / velocity  # [s]
    steps = math.ceil(period * fps)
    spawn = (1500.0, 1500.0, 0.4)
    env = plane_env(tmp_path, spawn, {"velocity": velocity, "wheelbase": wheelbase})
    poses = drive(env, [[steer]] * steps)
    xy = poses[:, :2]
    # least-squares circle through the rear axle's path
    a = np.c_[2 * xy, np.ones(len(xy))]
    (cx, cy, c), *_ = np.linalg.lstsq(a, (xy**2).sum(axis=1), rcond=None)
    measured = math.sqrt(c + cx * cx + cy * cy)
    assert measured == pytest.approx(radius, rel=1e-3)
    # the centre lies to the right (steer > 0) or left of the spawn: right is (-sin a, cos a)
    side = 1 if steer > 0 else -1
    right = (-math.sin(spawn[2]), math.cos(spawn[2]))
    assert cx == pytest.approx(spawn[0] + side * radius * right[0], abs=0.5)
    assert cy == pytest.approx(spawn[1] + side * radius * right[1], abs=0.5)
    # the heading turned a full circle, growing (clockwise on screen) when steering right
    assert (poses[-1][2] - spawn[2]) * side == pytest.approx(2 * math.pi * steps / fps / period)
    assert math.dist(xy[0], xy[-1]) < velocity / fps


def test_poses_follow_tinycarlos_bicycle_with_a_rate_limit(tmp_path):
    """Random steering with max_steering_change: the same poses as tinycarlo's arc steps."""
    velocity, wheelbase, fps, rate = 400.0, 150.0, 30, 180.0  # rate [deg/s]
    spawn = (1500.0, 1500.0, -0.7)
    env = plane_env(
        tmp_path,
        spawn,
        {"velocity": velocity, "wheelbase": wheelbase, "max_steering_change": rate},
    )
    actions = np.random.default_rng(3).uniform(-1, 1, (90, 1)).astype(np.float32)
    poses = drive(env, actions)
    pose, angle = spawn, 0.0
    for k, (action,) in enumerate(actions):
        target = action * 33.0
        angle += float(np.clip(target - angle, -rate / fps, rate / fps))
        pose = tinycarlo_step(pose, angle, velocity, wheelbase, 1 / fps)
        assert poses[k + 1] == pytest.approx(pose, abs=1e-3), k  # [px, px, rad]


def test_steering_rate_limit(tmp_path):
    """90 deg/s at 30 fps: the wheels reach full lock 3 degrees per step, then stay."""
    velocity, wheelbase, fps = 300.0, 160.0, 30
    env = plane_env(
        tmp_path,
        (1500.0, 1500.0, 0.0),
        {"velocity": velocity, "wheelbase": wheelbase, "max_steering_change": 90},
    )
    poses = drive(env, [[1.0]] * 15 + [[-1.0]] * 4)
    turns = np.diff(poses[:, 2])  # [rad/step]; the first step turns with the first angle
    # a step of exact arc at angle d turns the heading by v * tan(d) / wheelbase * dt
    angles = np.degrees(np.arctan(turns * wheelbase * fps / velocity))
    expected = [min(3 * k, 33) for k in range(1, 16)] + [30, 27, 24, 21]
    np.testing.assert_allclose(angles, expected, atol=1e-6)


def test_no_rate_limit_by_default(tmp_path):
    env = plane_env(tmp_path, (1500.0, 1500.0, 0.0), {"velocity": 300, "wheelbase": 160})
    poses = drive(env, [[1.0], [-0.5]])
    angles = np.degrees(np.arctan(np.diff(poses[:, 2]) * 160 * 30 / 300))
    np.testing.assert_allclose(angles, [33, -16.5], atol=1e-6)


# -- CarRacing's car on an image track ------------------------------------------------------


def dynamic_run(tmp_path, pixels_per_unit, actions):
    env = plane_env(
        tmp_path / str(pixels_per_unit),
        (600.0, 1500.0, 0.0),
        {"model": "dynamic", "pixels_per_unit": pixels_per_unit},
    )
    assert env.action_space.shape == (3,)  # [steer, gas, brake]
    return drive(env, actions)


def test_dynamic_car_moves_with_gas_in_scaled_pixels(tmp_path):
    idle = dynamic_run(tmp_path, 20, [[0, 0, 0]] * 20)
    np.testing.assert_allclose(idle[-1], idle[0])  # no gas, no motion
    gas = [[0, 1, 0]] * 20
    at_20, at_40 = dynamic_run(tmp_path, 20, gas), dynamic_run(tmp_path, 40, gas)
    moved_20 = at_20[-1][0] - at_20[0][0]
    assert moved_20 > 50  # forward along heading 0: +x
    assert abs(at_20[-1][1] - at_20[0][1]) < 1e-6 and at_20[-1][2] == pytest.approx(0)
    # the same motion in world units: twice the pixels at twice the scale
    assert at_40[-1][0] - at_40[0][0] == pytest.approx(2 * moved_20, rel=1e-6)


@pytest.mark.parametrize("steer", [1.0, -1.0])
def test_dynamic_car_steers_right_on_screen(tmp_path, steer):
    poses = dynamic_run(tmp_path, 20, [[0, 1, 0]] * 15 + [[steer, 0.2, 0]] * 15)
    heading_change = poses[-1][2] - poses[15][2]
    assert heading_change * steer > 0.1  # steer +1: heading grows, clockwise on screen
    # and the car ends up on that side of its straight path (y down: right is +y)
    assert (poses[-1][1] - poses[0][1]) * steer > 5
