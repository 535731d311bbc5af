"""Tracks in metres in the env: laps by the centreline driver in every car model each source
supports, collisions with cones and walls, units, the kinematic car with throttle, and
ConfigErrors naming the file and line of a bad track file."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.drivers.centerline import CenterlineDriver
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR

FOLDERS = {"centerline": "circuit", "cone_map": "autocross", "ros_map": "f1tenth_loop"}
# The dynamic car scaled to each example: metres per CarRacing world unit.
DYNAMIC_SCALE = {"centerline": 1.0, "cone_map": 0.6, "ros_map": 0.1}
MODELS = ("kinematic_throttle", "dynamic")


def make(kind: str, **overrides) -> gym.Env:
    return gym.make(
        "tinyrace/TinyRace-v0", environment=str(TRACKS_DIR / FOLDERS[kind]), **overrides
    )


def drive(env: gym.Env, act, limit: int = 10_000) -> tuple[dict, float, int]:
    """Drive with ``act(observation, info)`` until the episode ends; (last info, return, steps)."""
    observation, info = env.reset(seed=0)
    total = 0.0
    for step in range(1, limit + 1):
        observation, reward, terminated, truncated, info = env.step(act(observation, info))
        total += reward
        if terminated or truncated:
            return info, total, step
    return info, total, limit


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("kind", sorted(FOLDERS))
def test_the_centreline_driver_laps_every_source_in_every_car(kind, model):
    car = {"model": model}
    if model == "dynamic":
        car["pixels_per_unit"] = DYNAMIC_SCALE[kind]
    env = make(kind, car=car, sim={"step_limit": 10_000})
    driver = CenterlineDriver()
    env.reset(seed=0)
    driver.reset(env)
    info, total, steps = drive(env, driver.act)
    assert info["termination"] == "lap_finished"
    assert info["tiles_visited"] == info["tiles_total"]
    assert info["cones_hit"] == 0 and info["walls_hit"] == 0
    assert total == pytest.approx(1000 - 0.1 * steps)  # every tile once, 0.1 per step


def test_units_are_metres_and_speeds_metres_per_second():
    env = make("centerline")
    _, info = env.reset(seed=0)
    assert info["unit"] == "m"
    for _ in range(50):  # one second at full throttle from a standstill: 6 m/s^2
        _, _, _, _, info = env.step(np.array([0.0, 1.0], np.float32))
    assert info["speed"] == pytest.approx(6.0, rel=0.01)
    assert env.action_space.shape == (2,)


def test_a_cone_knocked_over_costs_once_and_may_end_the_episode():
    straight = lambda observation, info: np.array([0.0, 1.0], np.float32)  # noqa: E731
    env = make("cone_map", sim={"step_limit": 400})
    info, _, _ = drive(env, straight, 400)
    assert info["cones_hit"] >= 1
    env = make("cone_map", sim={"step_limit": 400})
    env.reset(seed=0)
    hits = []
    for _ in range(400):
        _, _, terminated, truncated, info = env.step(np.array([0.0, 1.0], np.float32))
        if "cones" in info["reward_terms"]:
            hits.append(info["reward_terms"]["cones"])
        if terminated or truncated:
            break
    assert hits and all(h <= -5.0 for h in hits)
    assert sum(hits) == -5.0 * info["cones_hit"]
    ends = make(
        "cone_map",
        track={
            "type": "cone_map",
            "file": "cones.csv",
            "cone_hit_ends_episode": True,
        },
    )
    info, _, _ = drive(ends, straight, 400)
    assert info["termination"] == "collision" and info["cones_hit"] >= 1


def test_a_wall_stops_the_car_costs_per_step_and_may_end_the_episode():
    straight = lambda observation, info: np.array([0.0, 1.0], np.float32)  # noqa: E731
    env = make("ros_map", sim={"step_limit": 300})
    env.reset(seed=0)
    stopped = []
    for _ in range(300):
        _, _, _, truncated, info = env.step(np.array([0.0, 1.0], np.float32))
        if "walls" in info["reward_terms"]:
            stopped.append(info["speed"])
        if truncated:
            break
    assert stopped and all(speed == 0.0 for speed in stopped)
    assert info["walls_hit"] == len(stopped)
    ends = make(
        "ros_map",
        track={
            "type": "ros_map",
            "file": "map.yaml",
            "waypoints": "raceline.csv",
            "wall_hit_ends_episode": True,
        },
    )
    info, _, _ = drive(ends, straight, 300)
    assert info["termination"] == "collision" and info["walls_hit"] == 1


def test_a_ros_map_without_waypoints_says_cte_and_lookahead_are_unavailable():
    env = make(
        "ros_map",
        track={"file": "map.yaml", "waypoints": None, "spawn": [13.3, 0.0, 1.73]},
    )
    _, info = env.reset(seed=0)
    assert "cte" not in info and "waypoints" in info["cte_unavailable"]
    with pytest.raises(ValueError, match="waypoints"):
        CenterlineDriver().reset(env)
    with pytest.raises(ConfigError) as error:
        make("ros_map", track={"file": "map.yaml", "waypoints": None})
    assert error.value.problems[0].path == "track.spawn"


# -- bad files through gym.make --------------------------------------------------------------
def copy_example(tmp_path: Path, kind: str) -> Path:
    folder = tmp_path / FOLDERS[kind]
    shutil.copytree(TRACKS_DIR / FOLDERS[kind], folder)
    return folder


@pytest.mark.parametrize(
    ("kind", "name", "line", "bad", "where"),
    [
        ("centerline", "circuit.csv", 5, "1.0,2.0,-3.0,4.0", "line 5, column 3 (w_tr_right_m)"),
        ("centerline", "circuit.csv", 7, "1.0,nan,3.0,4.0", "line 7, column 2"),
        ("cone_map", "cones.csv", 4, "green,1,2,0,0,0,0", "line 4, column 1 (tag)"),
        ("ros_map", "raceline.csv", 10, "1; 2; x; 4; 5; 6; 7", "line 10, column 3"),
        ("ros_map", "map.yaml", 2, "resolution: -0.05", "line 2 (resolution)"),
    ],
)
def test_a_bad_track_file_is_a_config_error_naming_file_and_line(
    tmp_path, kind, name, line, bad, where
):
    folder = copy_example(tmp_path, kind)
    lines = (folder / name).read_text().splitlines()
    lines[line - 1] = bad
    (folder / name).write_text("\n".join(lines) + "\n")
    with pytest.raises(ConfigError) as error:
        gym.make("tinyrace/TinyRace-v0", environment=str(folder))
    problem = error.value.problems[0]
    assert Path(problem.source).name == name and problem.path == where


def test_relative_paths_are_read_from_the_configs_folder(tmp_path):
    folder = copy_example(tmp_path, "centerline")
    (folder / "data").mkdir()
    (folder / "circuit.csv").rename(folder / "data" / "loop.csv")
    (folder / "track.yaml").write_text(
        yaml.safe_dump({"track": {"type": "centerline", "file": "data/loop.csv"}})
    )
    env = gym.make("tinyrace/TinyRace-v0", environment=str(folder))
    env.reset(seed=0)
    assert env.unwrapped.track.circuit.length == pytest.approx(2170, rel=0.01)


@pytest.mark.parametrize(
    ("kind", "model"), [("centerline", "kinematic"), ("image", "kinematic_throttle")]
)
def test_a_car_model_on_a_track_kind_it_cannot_drive_is_a_config_error(kind, model):
    environment = TRACKS_DIR / ("circuit" if kind == "centerline" else "formula_student")
    with pytest.raises(ConfigError) as error:
        gym.make("tinyrace/TinyRace-v0", environment=str(environment), car={"model": model})
    assert error.value.problems[0].path == "car.model"


def test_the_throttle_car_accelerates_brakes_caps_speed_and_turns_left_on_positive_steer():
    env = make("centerline", car={"velocity": 10.0, "max_steering_change": None})
    env.reset(seed=0)
    car = env.unwrapped.car
    for _ in range(200):  # 4 s at 6 m/s^2 would be 24 m/s: capped at 10
        env.step(np.array([0.0, 1.0], np.float32))
    assert car.speed == pytest.approx(10.0)
    for _ in range(25):  # 0.5 s at 10 m/s^2 brakes 5 m/s
        env.step(np.array([0.0, -1.0], np.float32))
    assert car.speed == pytest.approx(5.0)
    heading = car.pose[2]
    env.step(np.array([1.0, 0.0], np.float32))
    assert car.pose[2] > heading  # + left on tracks in metres: y up, the heading grows
    for _ in range(100):
        env.step(np.array([0.0, -1.0], np.float32))
    assert car.speed == 0.0  # no reverse
    assert math.isfinite(car.pose[0])


@pytest.mark.parametrize("kind", sorted(FOLDERS))
def test_pictures_show_the_track_and_the_car(kind):
    env = make(kind, render_mode="rgb_array", cameras=[])
    observation, _ = env.reset(seed=0)
    assert observation.shape == (96, 96, 3)
    assert (observation == (204, 0, 0)).all(axis=2).any()  # the car in the default view
    front = make(kind).reset(seed=0)[0]["front"]  # the example's camera: the road ahead
    assert front.shape == (96, 128, 3) and (front == (102, 102, 102)).all(axis=2).mean() > 0.2
    frame = env.render()
    assert frame.ndim == 3 and max(frame.shape[:2]) == 800
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 3


def test_an_image_track_may_declare_its_scale_and_keeps_pixels_without_it():
    folder = str(TRACKS_DIR / "formula_student")
    plain = gym.make("tinyrace/TinyRace-v0", environment=folder)
    plain.reset(seed=0)
    assert plain.unwrapped.layout.metres_per_unit is None
    scaled = gym.make(
        "tinyrace/TinyRace-v0",
        environment=folder,
        tracks=[
            {
                **yaml.safe_load((TRACKS_DIR / "formula_student" / "track.yaml").read_text())[
                    "tracks"
                ][0],
                "pixels_per_meter": 50.0,
            }
        ],
    )
    scaled.reset(seed=0)
    assert scaled.unwrapped.layout.metres_per_unit == pytest.approx(0.02)
    assert scaled.unwrapped.layout.unit == "px"


@pytest.mark.parametrize("kind", sorted(FOLDERS))
def test_metric_tracks_know_their_metres_per_unit(kind):
    env = make(kind)
    env.reset(seed=0)
    assert env.unwrapped.layout.metres_per_unit == 1.0 and env.unwrapped.layout.unit == "m"


def test_play_drives_the_throttle_car_with_the_arrow_keys():
    from types import SimpleNamespace

    from tinyrace.play import _action

    keys_of = SimpleNamespace(K_LEFT=0, K_RIGHT=1, K_UP=2, K_DOWN=3)
    env = make("cone_map").unwrapped
    # + left on tracks in metres: the right arrow is a negative steer
    assert _action(env, [0, 1, 1, 0], keys_of).tolist() == [-1.0, 1.0]  # right, throttle
    assert _action(env, [1, 0, 0, 1], keys_of).tolist() == [1.0, -1.0]  # left, brake
    assert env.action_space.contains(_action(env, [0, 0, 0, 0], keys_of))


def test_track_files_stay_in_the_configs_folder_unless_allowed(tmp_path):
    outside = str(TRACKS_DIR / "circuit" / "circuit.csv")
    track = {"type": "centerline", "file": outside}
    with pytest.raises(ConfigError) as error:
        gym.make("tinyrace/TinyRace-v0", config={"track": track})
    assert error.value.problems[0].path == "track.file"
    env = gym.make(
        "tinyrace/TinyRace-v0", config={"track": track, "files": {"paths_outside_folder": True}}
    )
    assert env.reset(seed=0)[1]["tiles_total"] == 1085
