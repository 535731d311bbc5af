"""tinyrace.rllib without Ray: the float-pixels wrappers (Gymnasium and PettingZoo) and the
env creator RLlib's env runners call. tests_train/test_rllib.py runs them under RLlib."""

from __future__ import annotations

import multiprocessing
import pickle
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from pettingzoo.test import parallel_api_test

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.errors import ConfigError
from tinyrace.race import parallel_env
from tinyrace.rllib import (
    FloatPixels,
    FloatPixelsParallel,
    FloatPixelsVector,
    float_space,
    is_pixels,
    make_env,
)
from tinyrace.vector import BatchVectorEnv

ROOT = Path(__file__).resolve().parents[1]
SENSORS = [
    {"id": "front", "type": "perspective_camera", "resolution": [30, 40]},
    {"id": "classes", "type": "perspective_camera", "resolution": [30, 40], "format": "classes"},
    {"id": "lidar", "type": "lidar", "beams": 8},
    {"id": "cones", "type": "cones", "max_cones": 4},
    {"id": "state", "type": "state"},
]


def test_importing_it_imports_neither_ray_nor_torch():
    code = (
        "import sys, tinyrace.rllib; "
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'ray', 'torch'}))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_carracing_pixels_become_the_same_picture_in_floats():
    plain = gym.make("tinyrace/CarRacing-v0", max_episode_steps=5)
    wrapped = FloatPixels(gym.make("tinyrace/CarRacing-v0", max_episode_steps=5))
    space = wrapped.observation_space
    assert isinstance(space, spaces.Box)
    assert (space.shape, space.dtype) == ((96, 96, 3), np.float32)
    assert space.low.min() == 0.0 and space.high.max() == 1.0
    expected, _ = plain.reset(seed=3)
    got, _ = wrapped.reset(seed=3)
    assert expected.dtype == np.uint8 and expected.max() > 100  # a real picture
    assert got.dtype == np.float32 and space.contains(got)
    np.testing.assert_array_equal(got, expected.astype(np.float32) / np.float32(255))
    np.testing.assert_array_equal(np.rint(got * 255).astype(np.uint8), expected)  # exact
    action = np.array([0.3, 0.5, 0.0], np.float32)
    expected, reward, *_ = plain.step(action)
    got, wrapped_reward, *_ = wrapped.step(action)
    assert wrapped_reward == reward
    np.testing.assert_array_equal(got, expected.astype(np.float32) / np.float32(255))


def test_a_dict_observation_has_its_cameras_in_floats_and_the_rest_as_it_was():
    plain = gym.make("tinyrace/TinyRace-v0", environment="formula_student", sensors=SENSORS)
    wrapped = FloatPixels(
        gym.make("tinyrace/TinyRace-v0", environment="formula_student", sensors=SENSORS)
    )
    space = wrapped.observation_space
    assert isinstance(space, spaces.Dict)
    images = {key for key, sub in plain.observation_space.spaces.items() if is_pixels(sub)}
    assert images == {"front", "front_camera", "classes"}  # RGB cameras and a class image
    for key, sub in space.spaces.items():
        if key in images:
            assert isinstance(sub, spaces.Box) and sub.dtype == np.float32
            assert sub.shape == plain.observation_space[key].shape
        else:
            assert sub == plain.observation_space[key]  # lidar, state, the cones' dict
    expected, _ = plain.reset(seed=1)
    got, _ = wrapped.reset(seed=1)
    assert space.contains(got)
    for key in images:
        np.testing.assert_array_equal(got[key], expected[key] / np.float32(255))
    np.testing.assert_array_equal(got["lidar"], expected["lidar"])
    np.testing.assert_array_equal(got["cones"]["cones"], expected["cones"]["cones"])
    assert got["cones"]["count"] == expected["cones"]["count"]


def test_spaces_without_images_pass_through():
    for space in (
        spaces.Box(0, 255, (8,), np.uint8),  # a vector of bytes: no image
        spaces.Box(0.0, 1.0, (4, 4, 3), np.float32),  # floats already
        spaces.Discrete(3),
    ):
        assert not is_pixels(space) and float_space(space) is space


class Context(dict):
    """Like RLlib's EnvContext: a dict with the runner's index as an attribute."""

    worker_index = 2


def test_make_env_makes_the_id_with_the_other_keys_as_keywords():
    env = make_env(Context(max_episode_steps=3))
    assert isinstance(env, FloatPixels)
    assert env.spec is not None and env.spec.id == "tinyrace/CarRacing-v0"  # the default id
    env.reset(seed=0)
    ends = [env.step(env.action_space.sample())[3] for _ in range(3)]
    assert ends == [False, False, True]  # max_episode_steps reached gym.make
    box = make_env({"id": "tinyrace/TinyRace-v0", "environment": "formula_student",
                    "observation": "box"})  # fmt: skip
    assert box.observation_space.shape == (120, 160, 3)
    assert box.observation_space.dtype == np.float32


def test_make_env_with_num_envs_gives_the_ids_vector_entry_point_in_float_pixels():
    """RLlib's vector_entry_point mode: the runner calls make_env(env_ctx | {"num_envs": n})."""
    vector = make_env(Context(num_envs=3, workers=0, max_episode_steps=4))
    plain = gym.make_vec("tinyrace/CarRacing-v0", num_envs=3, workers=0, max_episode_steps=4)
    try:
        assert isinstance(vector, FloatPixelsVector)
        assert isinstance(vector.unwrapped, BatchVectorEnv) and vector.num_envs == 3
        assert vector.single_observation_space == spaces.Box(0, 1, (96, 96, 3), np.float32)
        assert vector.observation_space == spaces.Box(0, 1, (3, 96, 96, 3), np.float32)
        assert vector.single_action_space == plain.single_action_space
        expected, _ = plain.reset(seed=7)
        got, _ = vector.reset(seed=7)
        np.testing.assert_array_equal(got, expected / np.float32(255))
        actions = np.tile(np.array([0.2, 0.6, 0.0], np.float32), (3, 1))
        ends = []
        for _ in range(5):  # past the time limit: the next-step autoreset's frame too
            expected, rewards, terminations, truncations, _ = plain.step(actions)
            got, got_rewards, got_terminations, got_truncations, _ = vector.step(actions)
            assert got.dtype == np.float32 and vector.observation_space.contains(got)
            np.testing.assert_array_equal(got, expected / np.float32(255))
            np.testing.assert_array_equal(got_rewards, rewards)
            np.testing.assert_array_equal(got_terminations, terminations)
            np.testing.assert_array_equal(got_truncations, truncations)
            ends.append(got_truncations.tolist())
        assert ends == [[False] * 3] * 3 + [[True] * 3] + [[False] * 3]  # step 5: the resets
    finally:
        vector.close()
        plain.close()


def test_the_vector_env_steps_in_the_runners_own_process_unless_workers_says_otherwise():
    """An RLlib env runner is a process with one CPU: no worker processes by default."""
    before = set(multiprocessing.active_children())
    vector = make_env({"num_envs": 2, "max_episode_steps": 3})
    try:
        assert set(multiprocessing.active_children()) == before
        vector.reset(seed=0)
        vector.step(np.zeros((2, 3), np.float32))
    finally:
        vector.close()
    vector = make_env({"num_envs": 2, "workers": 1, "max_episode_steps": 3})
    try:
        assert len(set(multiprocessing.active_children()) - before) == 1
    finally:
        vector.close()


def test_a_dict_observation_has_its_cameras_in_floats_in_the_vector_env_too():
    vector = make_env({"id": "tinyrace/TinyRace-v0", "num_envs": 2, "workers": 0,
                       "environment": "formula_student", "sensors": SENSORS})  # fmt: skip
    try:
        single = vector.single_observation_space
        assert isinstance(single, spaces.Dict)
        assert {k for k, sub in single.spaces.items() if sub.dtype == np.float32} >= {
            "front", "front_camera", "classes"
        }  # fmt: skip
        got, _ = vector.reset(seed=1)
        assert vector.observation_space.contains(got)
        assert got["front"].shape == (2, 30, 40, 3) and got["front"].dtype == np.float32
    finally:
        vector.close()


def test_workers_without_num_envs_names_the_mode_that_takes_them():
    """RLlib's sync and async modes ask make_env for one env: workers would reach the env."""
    with pytest.raises(
        ConfigError, match=r"<RLlib env_config>: workers: got 2; .*vector_entry_point"
    ):
        make_env({"workers": 2})


@pytest.mark.parametrize(
    ("config", "said"),
    [
        ("tinyrace/CarRacing-v0", "<RLlib env_config>: got 'tinyrace/CarRacing-v0'; expected a"),
        ({"id": 5}, "<RLlib env_config>: id: got 5; expected an env id"),
        ({"id": 5, "num_envs": 2}, "<RLlib env_config>: id: got 5; expected an env id"),
    ],
)
def test_an_env_config_that_is_no_dict_or_has_no_id_text_is_named(config, said):
    with pytest.raises(ConfigError) as caught:
        make_env(config)
    assert said in str(caught.value)


def test_make_env_in_a_fresh_process_registers_the_ids_itself():
    """What an env runner does: unpickle make_env (importing tinyrace), then call it."""
    code = (
        "import pickle, sys\n"
        "creator = pickle.loads(sys.stdin.buffer.read())\n"
        "print(creator({'max_episode_steps': 2}).observation_space.dtype)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT,
        input=pickle.dumps(make_env),
        capture_output=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr.decode()
    assert done.stdout.decode().strip() == "float32"


def test_the_race_wrapper_passes_pettingzoos_api_test_with_float_pixels():
    race = FloatPixelsParallel(parallel_env(num_agents=2, sim={"step_limit": 30}))
    parallel_api_test(race, num_cycles=10)
    observations, _ = race.reset(seed=0)
    assert race.agents == ["car_0", "car_1"] and race.possible_agents == race.agents
    for agent, observation in observations.items():
        space = race.observation_space(agent)
        assert isinstance(space, spaces.Box) and space.dtype == np.float32
        assert space.contains(observation) and observation.max() > 0.3
        assert race.action_space(agent) == race.unwrapped.action_space(agent)


def test_the_race_wrapper_gives_the_races_pixels_divided_by_255():
    plain = parallel_env(num_agents=2)
    wrapped = FloatPixelsParallel(parallel_env(num_agents=2))
    expected, _ = plain.reset(seed=5)
    got, _ = wrapped.reset(seed=5)
    actions = {agent: np.array([0.0, 0.4, 0.0], np.float32) for agent in plain.agents}
    expected_step, rewards, *_ = plain.step(actions)
    got_step, wrapped_rewards, *_ = wrapped.step(actions)
    assert wrapped_rewards == rewards
    for before, after in ((expected, got), (expected_step, got_step)):
        assert sorted(after) == sorted(before) == ["car_0", "car_1"]
        for agent in before:
            np.testing.assert_array_equal(after[agent], before[agent] / np.float32(255))
