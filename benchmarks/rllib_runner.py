"""RLlib's env runner on tinyrace: Gymnasium's SyncVectorEnv against the vector entry point.

``python benchmarks/rllib_runner.py [--envs N] [--rounds R] [--steps S]`` builds Ray 2.60's
``SingleAgentEnvRunner`` in this process on ``tinyrace/CarRacing-v0`` through
``tinyrace.rllib.make_env``, N envs each: ``gym_env_vectorize_mode="sync"`` (RLlib's
default: N single envs stepped in turn) and ``"vector_entry_point"`` (one
``BatchVectorEnv``, ``workers=0``: the envs stepped together in the runner's process),
one pair for random actions and one for the PPO module's. It samples S env-steps from
each in turn, R rounds, and prints the medians of env-steps per second and of this
thread's CPU time per env-step (the whole work: both step in this thread, and torch runs
on one thread), with random actions (the env and RLlib's episode bookkeeping) and with
the PPO module's actions (plus inference). The machine's load is printed before and after.

Needs Ray (``pip install ".[rllib]"``); without it the script says so and exits.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from typing import Any

import gymnasium as gym

MODES = ("sync", "vector_entry_point")
CONV_FILTERS = [[16, 8, 4], [32, 4, 2], [64, 3, 2]]  # docs/training.md's


def runner(mode: str, num_envs: int) -> Any:
    """A local SingleAgentEnvRunner of ``num_envs`` CarRacing-v0 envs in ``mode``."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    from ray.rllib.env.single_agent_env_runner import SingleAgentEnvRunner
    from ray.tune.registry import register_env
    from tinyrace.rllib import make_env

    register_env("tinyrace", make_env)
    env_config: dict[str, Any] = {"workers": 0} if mode == "vector_entry_point" else {}
    config = (
        PPOConfig()
        .environment("tinyrace", env_config=env_config)
        .env_runners(
            num_env_runners=0, num_envs_per_env_runner=num_envs, gym_env_vectorize_mode=mode
        )
        .rl_module(model_config=DefaultModelConfig(conv_filters=CONV_FILTERS))
        .debugging(seed=0)
    )
    return SingleAgentEnvRunner(config=config)


def measure(sampler: Any, steps: int, random_actions: bool) -> tuple[float, float]:
    """(env-steps/s, CPU s per env-step) of one ``sample`` call of ``steps`` env-steps."""
    start, cpu = time.perf_counter(), time.thread_time()
    sampler.sample(num_timesteps=steps, random_actions=random_actions)
    return steps / (time.perf_counter() - start), (time.thread_time() - cpu) / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=8)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=800, help="env-steps per sample call")
    args = parser.parse_args()
    try:
        import ray.rllib  # noqa: F401
    except ImportError as exc:
        print(f"rllib_runner: skipped, Ray's RLlib does not import here ({exc})")
        sys.exit(0)
    import torch

    torch.set_num_threads(1)  # inference in this thread too: its CPU time is the whole work
    gym.logger.min_level = gym.logger.ERROR
    print(f"load before: {os.getloadavg()}, cores: {os.cpu_count()}", flush=True)
    # a runner per kind of actions: RLlib's ongoing episodes do not take both (an episode
    # begun with random actions has no module outputs: validate() fails)
    kinds = [(mode, random) for random in (True, False) for mode in MODES]
    runners = {kind: runner(kind[0], args.envs) for kind in kinds}
    for (mode, random), sampler in runners.items():
        print(f"{mode}: {type(sampler.env.unwrapped).__name__} of {sampler.num_envs} envs")
        sampler.sample(num_timesteps=4 * args.envs, random_actions=random)  # warm-up
    results: dict[tuple[str, bool], list[tuple[float, float]]] = {kind: [] for kind in kinds}
    for round_ in range(args.rounds):
        for (mode, random), found in results.items():
            found.append(measure(runners[(mode, random)], args.steps, random))
        print(f"round {round_ + 1} done", flush=True)
    for sampler in runners.values():
        sampler.stop()
    print(f"\nmedians of {args.rounds} rounds of {args.steps} env-steps, {args.envs} envs:")
    for random in (True, False):
        rate = {m: statistics.median(r for r, _ in results[(m, random)]) for m in MODES}
        cpu = {m: statistics.median(c for _, c in results[(m, random)]) for m in MODES}
        sync, batch = MODES
        print(
            f"  {'random actions' if random else 'PPO module':>14}: sync {rate[sync]:,.0f} "
            f"env-steps/s ({cpu[sync] * 1e6:,.0f} us CPU), vector entry point "
            f"{rate[batch]:,.0f} ({cpu[batch] * 1e6:,.0f} us CPU): "
            f"{rate[batch] / rate[sync]:.2f}x steps/s, {cpu[sync] / cpu[batch]:.2f}x CPU"
        )
    print(f"load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
