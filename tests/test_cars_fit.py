"""Cars that fit the map: F1TENTH's size by default on ROS maps, start poses whose footprint
touches a wall or a cone refused by validate and gym.make (naming the file and key), wall
contacts counted in info and in the run's table."""

from __future__ import annotations

import csv
import math
import shutil
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.config import load_env_config
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.experiment import experiment_from_dict, run_experiment
from tinyrace.tracks.ros_map import read_map
from tinyrace.validate import validate_path

ROOT = Path(__file__).resolve().parents[1]
ONE_LINE = "track: {type: ros_map, file: map.yaml, waypoints: raceline.csv}"


def near_wall() -> list[float]:
    """A pose [m, m, rad] on a free cell of the f1tenth_loop map 0.1 m from a wall, facing it."""
    occupancy = read_map(TRACKS_DIR / "f1tenth_loop" / "map.yaml", "map.yaml", "file")
    walls = np.argwhere(occupancy.occupied)
    for row, col in np.argwhere(occupancy.free)[::97]:
        point = occupancy.to_world(np.array([row]), np.array([col]))[0]
        distance = np.hypot(*(occupancy.to_world(walls[:, 0], walls[:, 1]) - point).T)
        if 0.08 < distance.min() < 0.12:
            wall = occupancy.to_world(walls[[distance.argmin()], 0], walls[[distance.argmin()], 1])
            heading = math.atan2(*(wall[0] - point)[::-1])
            return [round(float(point[0]), 4), round(float(point[1]), 4), round(heading, 4)]
    raise AssertionError("no free cell 0.1 m from a wall")


SPAWN_NEAR_WALL = near_wall()


def ros_folder(tmp_path: Path, text: str) -> Path:
    for name in ("map.yaml", "map.png", "raceline.csv"):
        shutil.copy(TRACKS_DIR / "f1tenth_loop" / name, tmp_path / name)
    (tmp_path / "track.yaml").write_text(text + "\n")
    return tmp_path


def test_the_default_car_on_a_ros_map_is_f1tenth_sized(tmp_path):
    car = load_env_config(ros_folder(tmp_path, ONE_LINE) / "track.yaml").config.car
    assert (car.wheelbase, car.track_width) == (0.33, 0.31)  # F1TENTH: lf + lr, width [m]
    other = load_env_config(environment=TRACKS_DIR / "circuit").config.car
    assert other.wheelbase == 2.5  # other metric tracks keep their default


def test_the_docs_one_line_ros_map_config_starts_free(tmp_path):
    assert ONE_LINE in (ROOT / "docs" / "tracks.md").read_text()
    problems, summary = validate_path(ros_folder(tmp_path, ONE_LINE))
    assert problems == []
    assert "start free: car footprint 0.33 x 0.31 m" in summary
    assert "from the nearest wall" in summary


@pytest.mark.parametrize(
    ("text", "key", "value"),
    [
        ("track: {type: ros_map, file: map.yaml, waypoints: raceline.csv, spawn: "
         f"{SPAWN_NEAR_WALL}}}", "track.spawn", str(SPAWN_NEAR_WALL)),
        ("track: {type: ros_map, file: map.yaml, waypoints: raceline.csv}\n"
         "car: {wheelbase: 2.5, track_width: 1.6}", "track.waypoints", "raceline.csv"),
    ],
)  # fmt: skip
def test_a_start_pose_touching_a_wall_is_refused(tmp_path, text, key, value):
    folder = ros_folder(tmp_path, text)
    problems, _ = validate_path(folder)
    assert len(problems) == 1
    assert str(folder / "track.yaml") in problems[0] and key in problems[0]
    assert value in problems[0] and "overlaps a wall" in problems[0]
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", config=str(folder / "track.yaml"))
    assert key in str(caught.value)


def test_a_start_pose_on_a_cone_is_refused(tmp_path):
    source = TRACKS_DIR / "autocross"
    for item in source.iterdir():
        shutil.copy(item, tmp_path / item.name)
    config = yaml.safe_load((source / "track.yaml").read_text())
    config["car"] = {**config.get("car", {}), "track_width": 6.0}  # wider than the road
    (tmp_path / "track.yaml").write_text(yaml.safe_dump(config))
    problems, _ = validate_path(tmp_path)
    assert len(problems) == 1 and "track.file" in problems[0]
    assert "overlaps a cone" in problems[0]


def test_wall_contacts_are_counted_in_info_and_in_the_run_table(tmp_path):
    # full throttle straight ahead from the start: into the corridor's wall
    raw = {
        "env": {"environment": str(TRACKS_DIR / "f1tenth_loop"),
                "sim": {"step_limit": 400}},
        "driver": "constant", "driver_args": {"action": [0.0, 1.0]},
        "episodes": 1, "max_steps": 400, "output": {"video": False},
    }  # fmt: skip
    result = run_experiment(experiment_from_dict(raw, "walls.yaml", ROOT), tmp_path, False)
    with (result.run_dir / "episodes.csv").open(newline="") as handle:
        row = next(csv.DictReader(handle))
    hits = int(row["wall_hits"])
    assert hits > 0
    assert "walls" in (result.run_dir / "results.json").read_text()
    env = gym.make("tinyrace/TinyRace-v0", environment=str(TRACKS_DIR / "f1tenth_loop"))
    env.reset(seed=0)
    for _ in range(400):
        *_, info = env.step([0.0, 1.0])
    assert info["walls_hit"] == hits
