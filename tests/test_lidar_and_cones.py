"""The lidar and cone sensors on the tracks in metres: ranges to walls, classes of cones."""

from __future__ import annotations

import cv2
import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.sensors.lidar import WALL_CLASS
from tinyrace.sensors.machinery.common import color_mask
from tinyrace.tracks.cone_map import CLASSES

WALLS_AND_CONES = ["walls", "cones"]  # not off_road: the metric tracks' road edges are no walls


def make(folder: str, sensors: list[dict]) -> gym.Env:
    return gym.make(
        "tinyrace/TinyRace-v0", environment=str(TRACKS_DIR / folder), sensors=sensors, cameras=[]
    )


def test_the_lidar_sees_the_corridor_walls_at_their_distance():
    lidar = {"id": "lidar", "type": "lidar", "beams": 181, "fov": 180, "max_range": 30.0}
    env = make("f1tenth_loop", [{**lidar, "blocks": WALLS_AND_CONES, "hit_classes": True}])
    observation, _ = env.reset(seed=0)
    assert env.observation_space.contains(observation)
    ranges, classes = observation["lidar"]["ranges"], observation["lidar"]["classes"]
    base = env.unwrapped
    origin = base.sensors[-1].origin(base.snapshot(), base.layout)  # the front axle's middle
    clearance = base.track.occupancy.clearance(np.array([origin]))
    # beams 0 and 180 point right and left, across the corridor: the walls, about 1 m away
    for side in (0, 180):
        assert ranges[side] == pytest.approx(clearance[0], abs=0.1)
        assert classes[side] == WALL_CLASS
    assert ranges[90] > ranges[0]  # ahead, along the corridor


def test_the_lidar_tells_cones_by_class_and_misses_nothing_on_an_empty_track():
    lidar = {"id": "lidar", "type": "lidar", "blocks": WALLS_AND_CONES, "hit_classes": True}
    env = make("autocross", [{**lidar, "max_range": 20.0}])
    observation, _ = env.reset(seed=0)
    seen = set(np.unique(observation["lidar"]["classes"]).tolist())
    blue, yellow = (WALL_CLASS + CLASSES.index(c) + 1 for c in ("blue", "yellow"))
    assert {blue, yellow} <= seen
    empty = make("circuit", [{**lidar, "max_range": 25.0}])
    observation, _ = empty.reset(seed=0)
    assert (observation["lidar"]["ranges"] == 25.0).all()
    assert (observation["lidar"]["classes"] == 0).all()


def test_the_cone_sensor_lists_the_nearest_cones_in_the_cars_frame():
    cones = {"id": "cones", "type": "cones", "max_cones": 12, "max_range": 5.0, "fov": 360}
    env = make("autocross", [cones])
    observation, _ = env.reset(seed=0)
    rows, count = observation["cones"]["cones"], observation["cones"]["count"]
    assert env.observation_space.contains(observation)
    found = rows[:count]
    assert len(found) >= 4 and (found[:, 2] > 0).all() and (rows[count:] == 0).all()
    distance = np.hypot(found[:, 0], found[:, 1])
    assert np.all(np.diff(distance) >= 0) and distance[-1] <= 5.0  # nearest first, in range
    blue = found[found[:, 2] == CLASSES.index("blue") + 1]
    yellow = found[found[:, 2] == CLASSES.index("yellow") + 1]
    assert len(blue) and len(yellow)
    assert (blue[:, 1] > 0).all() and (yellow[:, 1] < 0).all()  # blue left, yellow right


def test_sensor_entries_are_checked():
    with pytest.raises(ConfigError) as error:
        make("autocross", [{"id": "r", "type": "radar"}])
    assert "lidar" in str(error.value) and "cones" in str(error.value)
    with pytest.raises(ConfigError) as error:
        make("autocross", [{"type": "lidar", "id": "x"}, {"type": "cones", "id": "x"}])
    assert error.value.problems[0].path == "sensors[1].id"


def test_picture_cones_smaller_than_a_cell_still_stop_beams():
    """formula_student's cones are 25 px discs; the default cell is 1/8 car length (18.75 px):
    the picture pools into cells, so the lidar still sees cones of both colours."""
    lidar = {"id": "lidar", "type": "lidar", "blocks": ["cones"], "hit_classes": True}
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment=str(TRACKS_DIR / "formula_student"),
        sensors=[{**lidar, "fov": 360, "max_range": 1500.0}],
        cameras=[],
    )
    observation, _ = env.reset(seed=0)
    sensor = env.unwrapped.sensors[-1]
    assert sensor.cell == pytest.approx(150 / 8)  # the track's wheelbase is 150 px
    seen = set(np.unique(observation["lidar"]["classes"]).tolist())
    assert {WALL_CLASS + 1, WALL_CLASS + 2} <= seen  # blue and yellow picture cones
    picture = env.unwrapped.layout.picture
    field = sensor.field
    for class_id, rgb in enumerate([(0, 0, 255), (255, 255, 0)], start=1):
        count, _, _, centres = cv2.connectedComponentsWithStats(
            color_mask(picture, rgb).astype(np.uint8)
        )
        assert count > 10
        cells = np.rint(centres[1:] @ field.to_cells[:, :2].T + field.to_cells[:, 2]).astype(int)
        # every cone's centre lies in a cell of its class: none fell between cell centres
        assert (field.classes[cells[:, 1], cells[:, 0]] == WALL_CLASS + class_id).all()
