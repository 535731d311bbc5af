"""gym.make_vec in every vectorization mode, and a one-camera image track as a plain Box."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.wrappers import FrameStackObservation, GrayscaleObservation, ResizeObservation

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.errors import ConfigError
from tinyrace.vector import BatchVectorEnv

IDS = {
    "tinyrace/CarRacing-v0": {},
    "tinyrace/TinyRace-v0": {"environment": "formula_student", "sim": {"step_limit": 6}},
}
ROOT = Path(__file__).resolve().parents[1]
STEPS = 8  # [steps] across one autoreset of the image track


def rollout(envs: gym.vector.VectorEnv, seed: int = 3) -> list[np.ndarray]:
    """Observations and rewards of a few steps with seeded random actions."""
    envs.action_space.seed(seed)
    observation, _ = envs.reset(seed=seed)
    trace = [_flat(observation)]
    for _ in range(STEPS):
        observation, reward, terminated, truncated, _ = envs.step(envs.action_space.sample())
        trace += [_flat(observation), reward, terminated, truncated]
    envs.close()
    return trace


def _flat(observation) -> np.ndarray:
    if isinstance(observation, dict):
        return np.concatenate([observation[k].ravel() for k in sorted(observation)])
    return observation.copy()


@pytest.mark.parametrize("env_id", IDS)
def test_vector_entry_point_is_the_batched_env_with_sync_results(env_id):
    kwargs = IDS[env_id]
    batched = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", **kwargs)
    assert isinstance(batched, BatchVectorEnv) and batched.num_envs == 3
    synced = gym.make_vec(env_id, num_envs=3, vectorization_mode="sync", **kwargs)
    assert isinstance(synced, gym.vector.SyncVectorEnv)
    for got, expected in zip(rollout(batched), rollout(synced), strict=True):
        np.testing.assert_array_equal(got, expected)


def test_make_vec_of_eight_defaults_to_the_batched_env():
    envs = gym.make_vec("tinyrace/CarRacing-v0", num_envs=8)
    try:
        assert isinstance(envs, BatchVectorEnv)
        observation, _ = envs.reset(seed=0)
        assert observation.shape == (8, 96, 96, 3)
        envs.step(envs.action_space.sample())
        assert envs.call("spec")[0].max_episode_steps == 1000  # CarRacing's TimeLimit
    finally:
        envs.close()


def test_make_vec_async_works():
    envs = gym.make_vec("tinyrace/CarRacing-v0", num_envs=2, vectorization_mode="async")
    try:
        assert isinstance(envs, gym.vector.AsyncVectorEnv)
        observation, _ = envs.reset(seed=0)
        observation, reward, *_ = envs.step(envs.action_space.sample())
        assert observation.shape == (2, 96, 96, 3) and reward.shape == (2,)
    finally:
        envs.close()


def test_one_camera_as_a_box_is_the_dict_observations_image():
    as_box = gym.make("tinyrace/TinyRace-v0", environment="segmented", observation="box")
    as_dict = gym.make("tinyrace/TinyRace-v0", environment="segmented")
    (camera,) = as_dict.observation_space.spaces
    assert as_box.observation_space == as_dict.observation_space[camera]
    box_obs, _ = as_box.reset(seed=4)
    dict_obs, _ = as_dict.reset(seed=4)
    np.testing.assert_array_equal(box_obs, dict_obs[camera])
    for _ in range(5):
        box_obs, *_ = as_box.step([0.3])
        dict_obs, *_ = as_dict.step([0.3])
    np.testing.assert_array_equal(box_obs, dict_obs[camera])
    check_env(as_box.unwrapped, skip_render_check=True)


def test_image_wrappers_apply_to_a_box_camera():
    env = gym.make("tinyrace/TinyRace-v0", environment="formula_student", observation="box")
    env = FrameStackObservation(ResizeObservation(GrayscaleObservation(env), (64, 64)), 4)
    observation, _ = env.reset(seed=0)
    assert observation.shape == env.observation_space.shape == (4, 64, 64)
    observation, *_ = env.step(env.action_space.sample())
    assert observation.dtype == np.uint8 and observation[-1].any()


def test_box_needs_exactly_one_camera():
    cameras = [{"id": "a", "roi": [100, 100]}, {"id": "b", "roi": [100, 100]}]
    with pytest.raises(ConfigError) as caught:
        gym.make(
            "tinyrace/TinyRace-v0", environment="segmented", cameras=cameras, observation="box"
        )
    (problem,) = caught.value.problems
    assert problem.path == "observation" and "exactly one camera" in problem.allowed


def test_box_vector_env_batches_the_image():
    envs = gym.make_vec(
        "tinyrace/TinyRace-v0", num_envs=2, environment="carolo_cup", observation="box"
    )
    try:
        observation, _ = envs.reset(seed=0)
        assert observation.shape == (2, 120, 160, 3)
    finally:
        envs.close()


def test_the_module_prefixed_id_registers_tinyrace_in_a_fresh_process():
    """RLlib's workers make the env by id alone: "tinyrace:<id>" imports tinyrace first."""
    code = (
        "import sys, gymnasium as gym\n"
        "env = gym.make('tinyrace:tinyrace/CarRacing-v0')\n"
        "observation, _ = env.reset(seed=0)\n"
        "assert 'tinyrace' in sys.modules\n"
        "print(observation.shape)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "(96, 96, 3)"


def test_the_training_page_uses_the_train_extra_and_ci_runs_its_test():
    page = (ROOT / "docs" / "training.md").read_text()
    # the install line works from a clone (no distribution of that name on the registry)
    assert 'pip install ".[train]"' in page and "pip install tinyrace" not in page
    assert "tinyrace train" in page
    assert "from tinyrace.rllib import make_env" in page and "PPOConfig" in page
    sb3 = next(b for b in page.split("```python")[1:] if "stable_baselines3" in b)
    assert '\nif __name__ == "__main__":\n    envs = ' in sb3  # SubprocVecEnv under the guard
    assert "](docs/training.md)" in (ROOT / "README.md").read_text()
    ci = (ROOT / ".ci" / "run").read_text()
    main_tests = ci.index('pip install -e ".[test]" && python -m pytest -q')
    train_stage = ci.index("torch==")
    # the training virtualenv: the built wheel with its train and rllib extras
    extras = ci.index('"tinyrace[train,rllib] @ file://$wheel"')
    assert main_tests < train_stage < extras < ci.index("tests_train")
    assert ci.index(" tinyrace train && ") > extras  # the README's command, as installed
