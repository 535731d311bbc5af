"""f1tenth_gym's car on request (issue 38, point 3): ``car.compat: f1tenth_gym`` drives as
f1tenth_gym's own code does, against trajectories recorded from it
(``tests/data/f1tenth_gym``: ``record.py`` says how; f1tenth_gym main at 4fdb9c7)."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pymunk
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.cars import single_track_model as st
from tinyrace.cars.single_track import SingleTrackCar
from tinyrace.errors import ConfigError

RECORDED = np.load(Path(__file__).resolve().parent / "data" / "f1tenth_gym" / "trajectories.npz")
NAMES = ("hold", "slalom", "slow", "random")
TOLERANCE = 1e-6  # [m] the issue's


def drive(name: str, compat: str | None) -> np.ndarray:
    """(steps + 1, 3) poses of tinyrace's car under the recorded actions, from the start."""
    space = pymunk.Space()
    start = tuple(RECORDED["start"].tolist())
    car = SingleTrackCar.build(space, start, st.PRESETS["f1tenth"], compat=compat)
    dt = float(RECORDED["dt"])
    poses = [car.pose]
    for steer, speed in RECORDED[f"{name}_actions"].tolist():
        car.control(steer, speed)
        car.apply_forces(dt)
        space.step(dt)
        poses.append(car.pose)
    return np.array(poses)


def differences(poses: np.ndarray, states: np.ndarray) -> tuple[float, float]:
    """Largest position [m] and heading [rad] differences from f1tenth_gym's states."""
    position = np.hypot(poses[:, 0] - states[:, 0], poses[:, 1] - states[:, 1])
    heading = np.angle(np.exp(1j * (poses[:, 2] - states[:, 4])))  # f1tenth_gym wraps its yaw
    return float(position.max()), float(np.abs(heading).max())


def test_the_recordings_are_f1tenth_gyms_at_the_issues_commit():
    assert str(RECORDED["commit"]).startswith("4fdb9c7")
    assert float(RECORDED["dt"]) == 0.01
    for name in NAMES:
        assert RECORDED[f"{name}_states"].shape == (501, 7)  # 5 s at 100 Hz


@pytest.mark.parametrize("name", NAMES)
def test_the_trajectory_is_f1tenth_gyms(name):
    states = RECORDED[f"{name}_states"]
    position, heading = differences(drive(name, "f1tenth_gym"), states)
    assert position < TOLERANCE and heading < TOLERANCE
    assert np.ptp(states[:, 0]) + np.ptp(states[:, 1]) > 2.0  # it went somewhere


def test_the_recordings_cover_what_compat_changes():
    """The low-speed model (below 0.5 m/s, reversing slowly too) and steering held long
    enough for the buffer and the bang-bang controller to show."""
    slow = RECORDED["slow_states"][:, 3]
    assert slow.min() < -0.2 and 0.0 < np.median(np.abs(slow[:150])) < 0.5
    assert RECORDED["random_states"][:, 3].max() > 5.0  # the tyre model, fast


@pytest.mark.parametrize("name", NAMES)
def test_tinyraces_own_car_differs(name):
    """Without the knob the car is tinyrace's (no buffer, a settling steering, the kinematic
    model about the centre of gravity): the comparison above can fail."""
    position, _ = differences(drive(name, None), RECORDED[f"{name}_states"])
    assert position > 1e-3


def env(**car: object) -> gym.Env:
    return gym.make(
        "tinyrace/TinyRace-v0",
        environment="circuit",  # room: a wide centreline track
        car={"model": "single_track", **car},
        sensors=[{"id": "lidar", "type": "lidar", "beams": 8}],
        cameras=[],
    )


def test_the_env_steps_f1tenth_gyms_car_at_its_rate():
    """Through gym.make: 100 Hz, the recorded motion (turned into the track's start frame),
    the lidar at the pose."""
    made = env(compat="f1tenth_gym")
    raw = made.unwrapped
    assert raw.dt == 0.01
    _, info = made.reset(seed=0)
    x0, y0, h0 = info["pose"]
    actions = RECORDED["hold_actions"][:300]
    poses = [info["pose"]]
    for action in actions:
        _, _, terminated, truncated, info = made.step(action.astype(np.float32))
        assert not (terminated or truncated) and info["walls_hit"] == 0
        poses.append(info["pose"])
    snapshot = raw.snapshot()
    sensor = raw.sensors[-1]
    assert sensor.origin(snapshot, raw.layout) == pytest.approx(snapshot.car.pose[:2])
    made.close()
    states = RECORDED["hold_states"][:301]
    sx, sy, sh = RECORDED["start"].tolist()
    c, s = math.cos(h0 - sh), math.sin(h0 - sh)  # the recording's frame onto the track's
    dx, dy = states[:, 0] - sx, states[:, 1] - sy
    expected = np.column_stack([x0 + c * dx - s * dy, y0 + s * dx + c * dy])
    poses_array = np.array(poses)
    assert np.max(np.hypot(*(poses_array[:, :2] - expected).T)) < TOLERANCE


@pytest.mark.parametrize(
    ("car", "sim", "key"),
    [
        ({"model": "kinematic_throttle", "compat": "f1tenth_gym"}, {}, "car.compat"),
        ({"model": "single_track", "compat": "f1tenth_gym", "actions": "raw"}, {}, "car.actions"),
        ({"model": "single_track", "compat": "f1tenth_gym"}, {"fps": 50}, "sim.fps"),
        ({"model": "single_track", "compat": "f1tenth_gym", "substeps": 4}, {}, "car.substeps"),
        ({"model": "single_track", "compat": "gym"}, {}, "car.compat"),
        ({"model": "single_track", "compat": "f1tenth_gym", "kinematic_below": 0.1}, {}, "car.kin"),
    ],
)
def test_what_compat_refuses(car, sim, key):
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment="circuit", car=car, sim=sim)
    assert key in str(caught.value)
