"""PPO's frames per second through tinyrace's SB3 VecEnv, SB3's SubprocVecEnv and CarRacing-v3.

``python benchmarks/vector_ppo.py [--envs N] [--timesteps T] [--workers W]`` trains
Stable-Baselines3's PPO (CnnPolicy, the same hyperparameters for every case, CPU torch)
for T timesteps on N envs, four frames stacked, and prints SB3's fps (timesteps per
second of wall time, rollouts and updates together) for:

- ``tinyrace_batch``: ``tinyrace.sb3.make_vec_env`` (W worker processes, the fast path);
- ``tinyrace_batch_parent``: the same with W - 1 workers and this process stepping a slice
  (``parent_steps=True``: ``make_vec_env``'s default layout for W cores);
- ``tinyrace_subproc``: SB3's ``SubprocVecEnv``, one process per env, same id;
- ``carracing_v3``: Gymnasium's ``CarRacing-v3`` in ``SubprocVecEnv`` (needs Box2D).

Needs ``stable-baselines3`` and torch (``pip install torch==2.13.0`` first, as .ci/run).
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym

HYPERPARAMETERS: dict[str, Any] = {"n_steps": 64, "batch_size": 128, "n_epochs": 1, "seed": 0}


def batch_envs(envs: int, workers: int, parent_steps: bool = False) -> Any:
    from stable_baselines3.common.vec_env import VecMonitor
    from tinyrace.sb3 import make_vec_env

    vec = make_vec_env("tinyrace/CarRacing-v0", envs, 0, workers, parent_steps=parent_steps)
    return VecMonitor(vec)


def subproc_envs(env_id: str, envs: int) -> Any:
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv

    return make_vec_env(env_id, n_envs=envs, seed=0, vec_env_cls=SubprocVecEnv)  # Monitor each


def fps(make: Callable[[], Any], timesteps: int) -> float:
    """PPO's timesteps per second on the envs ``make`` builds (frames stacked)."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecFrameStack

    torch.set_num_threads(1)
    envs = VecFrameStack(make(), 4)
    model = PPO("CnnPolicy", envs, **HYPERPARAMETERS)
    start = time.perf_counter()
    model.learn(timesteps)
    seconds = time.perf_counter() - start
    envs.close()
    return model.num_timesteps / seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=8)
    parser.add_argument("--timesteps", type=int, default=2048)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    args = parser.parse_args()
    gym.logger.min_level = gym.logger.ERROR
    cases: dict[str, Callable[[], Any]] = {
        "tinyrace_batch": lambda: batch_envs(args.envs, args.workers),
        "tinyrace_batch_parent": lambda: batch_envs(args.envs, max(args.workers - 1, 1), True),
        "tinyrace_subproc": lambda: subproc_envs("tinyrace:tinyrace/CarRacing-v0", args.envs),
        "carracing_v3": lambda: subproc_envs("CarRacing-v3", args.envs),
    }
    print(f"load before: {os.getloadavg()}; PPO CnnPolicy {HYPERPARAMETERS}, {args.envs} envs")
    results = {name: fps(make, args.timesteps) for name, make in cases.items()}
    for name, value in results.items():
        print(
            f"  {name:>21}: {value:8.1f} fps  {value / results['carracing_v3']:5.2f}x CarRacing-v3"
        )
    print(f"load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
