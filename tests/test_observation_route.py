"""One route to an observation: every observation is a sensor's. CarRacing's 96x96 view is
the ``chase_view`` sensor (a procedural track's default), a track in metres defaults to the
``top_view`` sensor, tinycarlo's ``cameras:`` are ``birdseye_camera`` sensors; the pictures
draw on the same ground as the sensors, and the human window draws no view twice a step."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.config import CameraConfig
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.race import parallel_env
from tinyrace.sensors.birdseye_camera import BirdseyeCamera
from tinyrace.sensors.chase_view import ChaseViewSensor
from tinyrace.sensors.top_view import TopViewSensor

ID = "tinyrace/TinyRace-v0"
CAROLO = {"environment": str(TRACKS_DIR / "carolo_cup")}
CIRCUIT = {"environment": str(TRACKS_DIR / "circuit")}
GAS = np.array([0.1, 0.6, 0.0], np.float32)  # steer, gas, brake: the car visits tiles


def drive(env: gym.Env, steps: int, frames: list | None = None) -> list[np.ndarray]:
    """The observations of a reset with seed 3 and ``steps`` steps of GAS (or no action on
    other cars); ``frames``: each step's ``render()`` is appended to it."""
    action = GAS if env.action_space.shape == (3,) else env.action_space.sample() * 0
    seen = [env.reset(seed=3)[0]]
    for k in range(steps + 1):
        if k:
            seen.append(env.step(action)[0])
        if frames is not None:
            frames.append(env.render())
    return seen


def test_carracing_observes_through_its_chase_view_sensor():
    env = gym.make("tinyrace/CarRacing-v0", render_mode="state_pixels")
    inner = env.unwrapped
    assert [type(s) for s in inner.sensors] == [ChaseViewSensor]
    assert env.observation_space == spaces.Box(0, 255, (96, 96, 3), np.uint8)
    frames: list[np.ndarray] = []
    seen = drive(env, 60, frames)  # tiles are visited: the ground is repainted
    for observation, frame in zip(seen, frames, strict=True):
        assert isinstance(observation, np.ndarray) and observation.dtype == np.uint8
        # the render layer draws its 96x96 frame on the ground the sensor sees
        assert np.array_equal(observation, frame)
    assert inner.episode.visit_order  # the drive did repaint tiles
    env.close()


def test_a_chase_view_sensor_entry_observes_what_the_default_does():
    default = gym.make(ID)
    entry = gym.make(ID, sensors=[{"id": "view", "type": "chase_view"}], observation="box")
    for ours, theirs in zip(drive(default, 30), drive(entry, 30), strict=True):
        assert np.array_equal(ours, theirs)


def test_a_track_in_metres_defaults_to_its_top_view_sensor():
    env = gym.make(ID, **CIRCUIT, cameras=[], render_mode="state_pixels")
    assert [type(s) for s in env.unwrapped.sensors] == [TopViewSensor]
    assert env.observation_space == spaces.Box(0, 255, (96, 96, 3), np.uint8)
    # a lidar-only env's frame draws the default view itself (the render layer's own route)
    lidar = gym.make(
        ID,
        **CIRCUIT,
        cameras=[],
        sensors=[{"id": "l", "type": "lidar"}],
        render_mode="state_pixels",
    )
    frames: list[np.ndarray] = []
    drive(lidar, 5, frames)
    for observation, frame in zip(drive(env, 5), frames, strict=True):
        assert np.array_equal(observation, frame)


def test_cameras_are_birdseye_camera_sensors_first_in_the_sensor_list():
    sensor = {"id": "state", "type": "state"}
    env = gym.make(ID, **CAROLO, sensors=[sensor])
    config = env.unwrapped.config
    assert isinstance(config.sensors[0], CameraConfig)
    assert config.sensors[0] == config.cameras[0]  # as written, its type birdseye_camera
    assert [s.id for s in config.sensors] == ["front_camera", "state"]
    assert isinstance(env.unwrapped.sensors[0], BirdseyeCamera)
    observation, _ = env.reset(seed=0)
    assert list(observation) == ["front_camera", "state"]


def test_a_birdseye_camera_sensor_entry_sees_what_a_camera_entry_does():
    camera = {"id": "cam", "resolution": [30, 40], "roi": [300, 400]}
    by_cameras = gym.make(ID, **CAROLO, cameras=[camera])
    by_sensors = gym.make(ID, **CAROLO, cameras=[], sensors=[{**camera, "type": "birdseye_camera"}])
    assert by_cameras.observation_space == by_sensors.observation_space
    for ours, theirs in zip(drive(by_cameras, 5), drive(by_sensors, 5), strict=True):
        assert ours.keys() == theirs.keys() == {"cam"}
        assert np.array_equal(ours["cam"], theirs["cam"])


def counted(env: gym.Env) -> dict[str, int]:
    """Calls of each sensor's ``observe``, by sensor id, counted from now on."""
    calls: dict[str, int] = {}
    for sensor in env.unwrapped.sensors:
        calls[sensor.id] = 0

        def observe(*args, _sensor=sensor, _observe=sensor.observe):
            calls[_sensor.id] += 1
            return _observe(*args)

        sensor.observe = observe
    return calls


@pytest.mark.usefixtures("no_display")
@pytest.mark.parametrize(
    "kwargs",
    [{}, CAROLO, {**CAROLO, "sensors": [{"id": "lidar", "type": "lidar"}]}, CIRCUIT],
    ids=["carracing", "camera", "camera_and_lidar", "metric"],
)
def test_the_human_window_draws_each_view_once_per_step(kwargs):
    env = gym.make(ID, render_mode="human", sim={"render_realtime": False}, **kwargs)
    calls = counted(env)
    assert calls  # every env observes through sensors
    env.reset(seed=0)
    assert set(calls.values()) == {1}
    steps = 4
    for _ in range(steps):
        env.step(env.action_space.sample() * 0)
    assert set(calls.values()) == {1 + steps}
    env.close()


@pytest.mark.parametrize("kwargs", [CAROLO, CIRCUIT, {**CIRCUIT, "cameras": []}])
def test_a_frame_of_this_steps_views_is_the_frame_of_views_drawn_anew(kwargs):
    env = gym.make(ID, render_mode="rgb_array", **kwargs)
    inner = env.unwrapped
    drive(env, 3)
    reused = env.render()
    inner._observed = None  # the views are drawn again for this frame
    assert np.array_equal(reused, env.render())


def test_race_cars_see_through_sensors_their_own_cameras_first():
    rear = {"id": "rear", "resolution": [20, 30], "roi": [10.0, 15.0], "yaw": 180.0}
    state = {"id": "s", "type": "state"}
    cars = [
        {"id": "shared"},
        {"id": "own_cameras", "cameras": [rear]},
        {"id": "own_sensors", "sensors": [state]},
    ]
    env = parallel_env(
        **CIRCUIT, sensors=[{"id": "l", "type": "lidar", "beams": 8}], race={"cars": cars}
    )
    keys = {
        agent: [sensor.id for sensor in seat.sensors]
        for agent, seat in zip(env.possible_agents, env.seats, strict=True)
    }
    # a car's cameras (its own, else the shared) come first, then its sensors (its own, else
    # the shared ones); each car's cameras are birdseye_camera sensors like car 0's
    assert keys == {
        "shared": ["front", "l"],
        "own_cameras": ["rear", "l"],
        "own_sensors": ["front", "s"],
    }
    assert isinstance(env.seats[1].sensors[0], BirdseyeCamera)
    for agent, ids in keys.items():
        assert set(env.observation_space(agent).spaces) == set(ids)
    observations, _ = env.reset(seed=0)
    for agent in env.agents:
        assert observations[agent] in env.observation_space(agent)
    assert observations["own_cameras"]["rear"].shape == (20, 30, 3)


def test_a_race_cars_bad_camera_is_named_by_the_key_written():
    bad = {"id": "bad", "type": "chase_view"}  # a procedural view on a track in metres
    cars = [{}, {"sensors": [bad]}]
    with pytest.raises(ConfigError, match=r"race\.cars\[1\]\.sensors\[0\]\.type"):
        parallel_env(**CIRCUIT, race={"cars": cars})


def test_every_race_car_without_sensors_observes_its_default_view():
    env = parallel_env(race={"num_agents": 2})  # CarRacing's track: chase_view for each car
    for agent, seat in zip(env.possible_agents, env.seats, strict=True):
        assert [type(s) for s in seat.sensors] == [ChaseViewSensor]
        assert env.observation_space(agent) == spaces.Box(0, 255, (96, 96, 3), np.uint8)
    observations, _ = env.reset(seed=0)
    assert all(isinstance(o, np.ndarray) and o.shape == (96, 96, 3) for o in observations.values())
    metric = parallel_env(**CIRCUIT, cameras=[], race={"num_agents": 2})
    assert [type(s) for seat in metric.seats for s in seat.sensors] == [TopViewSensor] * 2
