"""RLlib's env runners step tinyrace's vector entry point: with
``gym_env_vectorize_mode="vector_entry_point"`` RLlib 2.60's ``SingleAgentEnvRunner`` asks
``make_env`` for ``num_envs_per_env_runner`` envs at once and gets one ``BatchVectorEnv``.

The runner's recorded episodes are replayed on single ``gym.make`` envs (same seeds, the
episodes' actions): the same observations and rewards, across Gymnasium's next-step
autoreset, which RLlib's sampling loop expects. Then PPO trains an iteration on remote env
runners (processes of Ray's own) whose envs are BatchVectorEnvs.

Run by .ci/run's train stage (``pip install -e ".[train,rllib]"``).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import ray
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
from ray.rllib.env.single_agent_env_runner import SingleAgentEnvRunner
from ray.tune.registry import register_env

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.rllib import FloatPixelsVector, make_env
from tinyrace.vector import BatchVectorEnv

EPISODE = 10  # [steps] per episode: 30 timesteps of 3 envs end one episode each
NUM_ENVS = 3
SEED = 5
CONV_FILTERS = [[16, 8, 4], [32, 4, 2], [64, 3, 2]]  # docs/training.md's, for any camera


def _config(workers: int | None, mode: str = "vector_entry_point") -> PPOConfig:
    register_env("tinyrace", make_env)
    env_config = {"max_episode_steps": EPISODE}
    if workers is not None:
        env_config["workers"] = workers
    return (
        PPOConfig()
        .environment("tinyrace", env_config=env_config)
        .env_runners(
            num_env_runners=0, num_envs_per_env_runner=NUM_ENVS, gym_env_vectorize_mode=mode
        )
        .rl_module(model_config=DefaultModelConfig(conv_filters=CONV_FILTERS))
        .debugging(seed=SEED)
    )


def _replay(env: gym.Env, episode: Any, seed: int | None) -> None:
    """Step ``env`` through ``episode``'s actions; its observations and rewards must match."""
    observations = episode.get_observations()
    actions, rewards = episode.get_actions(), episode.get_rewards()
    first, _ = env.reset(seed=seed)
    np.testing.assert_array_equal(observations[0], first.astype(np.float32) / np.float32(255))
    for t, action in enumerate(actions):
        observation, reward, terminated, truncated, _ = env.step(action)
        assert reward == rewards[t], (t, reward, rewards[t])
        np.testing.assert_array_equal(
            observations[t + 1], observation.astype(np.float32) / np.float32(255)
        )
    assert truncated and not terminated and episode.is_truncated  # the time limit, as RLlib saw


@pytest.mark.parametrize("workers", [0, 1])
def test_the_env_runner_steps_one_batch_vector_env_with_single_envs_results(workers: int):
    runner = SingleAgentEnvRunner(config=_config(workers))
    try:
        assert isinstance(runner.env.unwrapped, BatchVectorEnv)
        assert runner.env.unwrapped.num_envs == NUM_ENVS == runner.num_envs
        assert isinstance(runner.env.env, FloatPixelsVector)  # inside RLlib's DictInfoToList
        assert runner.env.single_observation_space == gym.spaces.Box(0, 1, (96, 96, 3), np.float32)
        first = runner.sample(num_timesteps=NUM_ENVS * EPISODE, random_actions=True)
        # the next episodes begin with the vector env's autoreset (Gymnasium's next step)
        second = runner.sample(num_timesteps=NUM_ENVS * EPISODE, random_actions=True)
    finally:
        runner.stop()
    assert len(first) == len(second) == NUM_ENVS
    singles = [
        gym.make("tinyrace/CarRacing-v0", max_episode_steps=EPISODE) for _ in range(NUM_ENVS)
    ]
    for index, (env, episode) in enumerate(zip(singles, first, strict=True)):
        assert len(episode) == EPISODE
        _replay(env, episode, SEED + index)  # BatchVectorEnv seeds env i with seed + i
    for env, episode in zip(singles, second, strict=True):
        _replay(env, episode, None)  # the autoreset: no new seed
        env.close()


def test_rllibs_default_sync_mode_makes_n_single_envs_instead():
    """The switch is the config's: without it RLlib builds a SyncVectorEnv of make_env's
    single envs (each a FloatPixels), which steps them one after the other."""
    runner = SingleAgentEnvRunner(config=_config(None, mode="sync"))
    try:
        assert isinstance(runner.env.unwrapped, gym.vector.SyncVectorEnv)
        assert not isinstance(runner.env.unwrapped, BatchVectorEnv)
        assert len(runner.env.unwrapped.envs) == NUM_ENVS
        assert runner.env.single_observation_space.dtype == np.float32  # FloatPixels each
    finally:
        runner.stop()


def test_ppo_trains_an_iteration_on_remote_env_runners_that_step_batch_vector_envs():
    ray.init(num_cpus=2, include_dashboard=False)
    try:
        config = (
            _config(0)
            .environment("tinyrace", env_config={"max_episode_steps": 50, "workers": 0})
            .env_runners(num_env_runners=2, num_envs_per_env_runner=2, rollout_fragment_length=50)
            .training(train_batch_size_per_learner=200, minibatch_size=100, num_epochs=1)
        )
        algo = config.build_algo()
        try:
            remote = algo.env_runner_group.foreach_env_runner(
                lambda runner: (type(runner.env.unwrapped).__name__, runner.num_envs),
                local_env_runner=False,
            )
            assert remote == [("BatchVectorEnv", 2)] * 2  # each runner's own process
            runners = algo.train()["env_runners"]
        finally:
            algo.stop()
    finally:
        ray.shutdown()
    # 2 runners x 2 envs x 50 steps: each env ends one 50-step episode
    assert runners["num_env_steps_sampled"] == 200, runners
    assert runners["num_episodes"] == 4, runners
    assert np.isfinite(runners["episode_return_mean"])


def test_rllibs_multi_agent_runner_vectorizes_in_sync_mode_only():
    """Where RLlib does not allow it (docs/training.md): the PettingZoo race goes through
    MultiAgentEnvRunner, whose make_vec (ray/rllib/env/vector/registration.py) builds a
    SyncVectorMultiAgentEnv and refuses every other mode."""
    from ray.rllib.env.multi_agent_env_runner import MultiAgentEnvRunner
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    from tinyrace.race import parallel_env
    from tinyrace.rllib import FloatPixelsParallel

    register_env(
        "race", lambda config: ParallelPettingZooEnv(FloatPixelsParallel(parallel_env(**config)))
    )
    config = (
        PPOConfig()
        .environment("race", env_config={"num_agents": 2})
        .multi_agent(policies={"shared"}, policy_mapping_fn=lambda agent, episode, **kw: "shared")
        .env_runners(num_env_runners=0, num_envs_per_env_runner=2)
        .rl_module(model_config=DefaultModelConfig(conv_filters=CONV_FILTERS))
    )
    with pytest.raises(ValueError, match="only synchronous environment vectorization"):
        MultiAgentEnvRunner(config=config.env_runners(gym_env_vectorize_mode="vector_entry_point"))
    runner = MultiAgentEnvRunner(config=config.env_runners(gym_env_vectorize_mode="sync"))
    try:
        assert runner.num_envs == 2  # two races, stepped one after the other
    finally:
        runner.stop()
