"""The lidar on ROS maps crosses the map's pixels exactly: against an Amanatides-Woo traversal
of the occupied pixels (tests/lidar_reference.py) on a generated map with one-pixel,
diagonal and round walls, the numpy twin identical to the compiled path; by default it
stops at the map's walls, not at a band around the waypoints."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np
import pytest
import yaml
from lidar_reference import scan as reference_scan

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.sensors.lidar import LidarSensor

RESOLUTION = 0.05  # [m/px]
BEAMS = 1080
MAX_RANGE = 20.0  # [m]


def walls_map(height: int = 240, width: int = 320) -> np.ndarray:
    """(H, W) bool: a frame, one-pixel walls across and along, 8-connected diagonals at
    45 deg and shallower, one-pixel dots and a round pillar."""
    occupied = np.zeros((height, width), np.uint8)
    cv2.rectangle(occupied, (0, 0), (width - 1, height - 1), 1, 1)
    occupied[60, 20:200] = 1  # one pixel thick
    occupied[100:220, 250] = 1
    cv2.line(occupied, (30, 90), (150, 210), 1, 1, cv2.LINE_8)  # 45 deg, corners touching
    cv2.line(occupied, (160, 100), (300, 150), 1, 1, cv2.LINE_8)  # shallow
    cv2.line(occupied, (210, 20), (240, 200), 1, 1, cv2.LINE_8)  # steep
    cv2.circle(occupied, (90, 150), 12, 1, -1)
    occupied[30:200:17, 280] = 1  # single pixels
    return occupied.astype(bool)


def write_map(folder: Path, occupied: np.ndarray, origin: list[float], extra: str = "") -> Path:
    picture = np.where(occupied, 0, 254).astype(np.uint8)
    cv2.imwrite(str(folder / "map.png"), picture)
    info = {"image": "map.png", "resolution": RESOLUTION, "origin": origin, "negate": 0,
            "occupied_thresh": 0.65, "free_thresh": 0.196}  # fmt: skip
    (folder / "map.yaml").write_text(yaml.safe_dump(info) + extra)
    return folder / "map.yaml"


def lidar_env(folder: Path, spawn: list[float], **lidar) -> gym.Env:
    sensor = {"id": "lidar", "type": "lidar", "beams": BEAMS, "fov": 360,
              "max_range": MAX_RANGE, **lidar}  # fmt: skip
    config = {
        "track": {"type": "ros_map", "file": "map.yaml", "spawn": spawn},
        "car": {"model": "kinematic_throttle", "wheelbase": 0.33, "track_width": 0.3},
        "sensors": [sensor],
    }
    (folder / "env.yaml").write_text(yaml.safe_dump(config))
    return gym.make("tinyrace/TinyRace-v0", config=str(folder / "env.yaml"))


def free_poses(
    occupied: np.ndarray, origin: list[float], count: int, seed: int
) -> list[tuple[float, float, float]]:
    """Poses [m, m, rad] on free pixels (world from the map's numbers), at random."""
    rng = np.random.default_rng(seed)
    height, width = occupied.shape
    ox, oy, yaw = origin
    c, s = math.cos(yaw), math.sin(yaw)
    poses = []
    while len(poses) < count:
        u, v = rng.uniform(1, width - 1), rng.uniform(1, height - 1)  # [px] from lower left
        if occupied[height - 1 - int(v), int(u)]:
            continue
        lx, ly = u * RESOLUTION, v * RESOLUTION
        poses.append((ox + c * lx - s * ly, oy + s * lx + c * ly, rng.uniform(-math.pi, math.pi)))
    return poses


def sensors(env: gym.Env) -> list:
    return list(env.unwrapped.sensors)


@pytest.mark.parametrize("origin", [[-3.0, -2.0, 0.0], [1.5, -4.0, 0.4]])
def test_the_lidar_matches_an_exact_traversal_of_the_pixels(tmp_path, origin):
    occupied = walls_map()
    write_map(tmp_path, occupied, origin)
    poses = free_poses(occupied, origin, 200, seed=1)
    env = lidar_env(tmp_path, list(poses[0]))
    env.reset(seed=0)
    lidar = sensors(env)[0]
    twin = LidarSensor(lidar.config, MAX_RANGE, lidar.cell, (), "numpy", exact_only=True)
    twin.reset(env.unwrapped.layout)
    errors = []
    for x, y, heading in poses:
        ranges = lidar.scan((x, y), heading, False)
        assert np.array_equal(ranges, twin.scan((x, y), heading, False)), "numpy twin"
        expected = reference_scan(
            occupied, RESOLUTION, tuple(origin), (x, y), heading + lidar.angles, MAX_RANGE
        )
        errors.append(np.abs(ranges - expected))
    error = np.concatenate(errors)
    assert lidar.kernel in ("numba", "numpy")
    assert np.median(error) <= 0.01  # [m]
    assert np.percentile(error, 99) <= RESOLUTION
    assert error.max() < 1e-4  # exact up to float32 ranges


def test_the_observation_is_the_scan_from_the_mount(tmp_path):
    occupied = walls_map()
    origin = [-3.0, -2.0, 0.0]
    write_map(tmp_path, occupied, origin)
    spawn = [4.0, 2.0, 0.7]
    env = lidar_env(tmp_path, spawn, mount="rear_axle", position=[0.275, 0.0])
    observation, _ = env.reset(seed=0)
    state = env.unwrapped.snapshot().car
    x, y = state.rear_axle
    heading = state.pose[2]
    start = (x + 0.275 * math.cos(heading), y + 0.275 * math.sin(heading))
    expected = reference_scan(
        occupied, RESOLUTION, tuple(origin), start, heading + sensors(env)[0].angles, MAX_RANGE
    )
    assert np.abs(observation["lidar"] - expected).max() < 1e-4


def test_a_round_room_with_waypoints_stops_beams_at_its_walls(tmp_path):
    # a room of radius 8 m; the waypoints a 5 m circle inside it: the default blocks are the
    # walls, so every beam from the centre reads about 8 m
    size = 400
    occupied = np.ones((size, size), np.uint8)
    cv2.circle(occupied, (size // 2, size // 2), round(8.0 / RESOLUTION), 0, -1)
    origin = [-size / 2 * RESOLUTION, -size / 2 * RESOLUTION, 0.0]
    write_map(tmp_path, occupied.astype(bool), origin)
    angles = np.linspace(0, 2 * math.pi, 100, endpoint=False)
    rows = "\n".join(f"{5 * math.cos(a):.4f}, {5 * math.sin(a):.4f}" for a in angles)
    (tmp_path / "line.csv").write_text("# x_m, y_m\n" + rows + "\n")
    sensor = {"id": "lidar", "type": "lidar", "beams": 360, "fov": 360, "max_range": 30}
    config = {"track": {"type": "ros_map", "file": "map.yaml", "waypoints": "line.csv"},
              "car": {"model": "kinematic_throttle", "wheelbase": 0.33, "track_width": 0.3},
              "sensors": [sensor]}  # fmt: skip
    (tmp_path / "env.yaml").write_text(yaml.safe_dump(config))
    env = gym.make("tinyrace/TinyRace-v0", config=str(tmp_path / "env.yaml"))
    env.reset(seed=0)
    ranges = sensors(env)[0].scan((0.0, 0.0), 0.3, False)
    assert ranges.min() > 7.9 and ranges.max() < 8.1
