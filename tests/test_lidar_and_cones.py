"""The lidar and cone sensors on the tracks in metres: ranges to walls, classes of cones."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.sensors.lidar import WALL_CLASS
from tinyrace.tracks.cone_map import CLASSES


def make(folder: str, sensors: list[dict]) -> gym.Env:
    return gym.make(
        "tinyrace/TinyRace-v0", environment=str(TRACKS_DIR / folder), sensors=sensors, cameras=[]
    )


def test_the_lidar_sees_the_corridor_walls_at_their_distance():
    env = make("f1tenth_loop", [{"type": "lidar", "beams": 181, "fov": 180}])
    observation, _ = env.reset(seed=0)
    assert env.observation_space.contains(observation)
    ranges, classes = observation["lidar"]["ranges"], observation["lidar"]["classes"]
    clearance = env.unwrapped.track.occupancy.clearance(np.array([env.unwrapped.car.pose[:2]]))
    # beams 0 and 180 point right and left, across the corridor: the walls, about 1 m away
    for side in (0, 180):
        assert ranges[side] == pytest.approx(clearance[0], abs=0.1)
        assert classes[side] == WALL_CLASS
    assert ranges[90] > ranges[0]  # ahead, along the corridor


def test_the_lidar_tells_cones_by_class_and_misses_nothing_on_an_empty_track():
    env = make("autocross", [{"type": "lidar", "max_range": 20.0}])
    observation, _ = env.reset(seed=0)
    seen = set(np.unique(observation["lidar"]["classes"]).tolist())
    blue, yellow = (WALL_CLASS + CLASSES.index(c) + 1 for c in ("blue", "yellow"))
    assert {blue, yellow} <= seen
    empty = make("circuit", [{"type": "lidar", "max_range": 25.0}])
    observation, _ = empty.reset(seed=0)
    assert (observation["lidar"]["ranges"] == 25.0).all()
    assert (observation["lidar"]["classes"] == 0).all()


def test_the_cone_sensor_lists_the_nearest_cones_in_the_cars_frame():
    env = make("autocross", [{"type": "cones", "count": 12, "max_range": 5.0}])
    observation, _ = env.reset(seed=0)
    rows = observation["cones"]
    assert env.observation_space.contains(observation)
    found = rows[rows[:, 3] > 0]
    assert len(found) >= 4
    assert np.all(np.diff(found[:, 2]) >= 0)  # nearest first
    assert np.allclose(np.hypot(found[:, 0], found[:, 1]), found[:, 2], atol=1e-4)
    blue = found[found[:, 3] == CLASSES.index("blue") + 1]
    yellow = found[found[:, 3] == CLASSES.index("yellow") + 1]
    assert len(blue) and len(yellow)
    assert (blue[:, 1] > 0).all() and (yellow[:, 1] < 0).all()  # blue left, yellow right


def test_sensor_entries_are_checked():
    with pytest.raises(ConfigError) as error:
        make("autocross", [{"type": "radar"}])
    assert "lidar" in str(error.value) and "cones" in str(error.value)
    with pytest.raises(ConfigError) as error:
        make("autocross", [{"type": "lidar", "id": "x"}, {"type": "cones", "id": "x"}])
    assert error.value.problems[0].path == "sensors[1].id"
