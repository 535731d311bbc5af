"""Train a PPO agent on tinyrace/CarRacing-v0 from pixels with Stable-Baselines3.

Needs the ``train`` extra (``pip install torch`` first for a CPU build, then
``pip install "tinyrace[train]"``). Run it from any folder::

    python examples/train_ppo.py --timesteps 200000 --envs 4

It saves ``ppo_carracing.zip`` and prints the mean return of a few evaluation
episodes. ``train`` and ``evaluate`` are what docs/training.md's example shows.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.vec_env import SubprocVecEnv, VecFrameStack

import tinyrace  # noqa: F401  (registers tinyrace/CarRacing-v0)

ENV_ID = "tinyrace/CarRacing-v0"


def make_envs(n_envs: int, seed: int, subprocesses: bool = True, **env_kwargs):
    """``n_envs`` CarRacing envs (one process each when ``subprocesses``), 4 frames stacked.

    ``env_kwargs`` go to ``gym.make`` (e.g. ``domain_randomize=True``, ``max_episode_steps``).
    """
    envs = make_vec_env(
        ENV_ID,
        n_envs=n_envs,
        seed=seed,
        env_kwargs=env_kwargs,
        vec_env_cls=SubprocVecEnv if subprocesses and n_envs > 1 else None,
    )
    return VecFrameStack(envs, n_stack=4)  # stacked on the channel axis: (96, 96, 12)


def train(
    timesteps: int, n_envs: int = 4, seed: int = 0, subprocesses: bool = True, **ppo_args
) -> PPO:
    """A PPO agent with SB3's Atari-style CNN, trained for ``timesteps`` env steps."""
    envs = make_envs(n_envs, seed, subprocesses)
    settings = {"n_steps": 512, "batch_size": 128, "learning_rate": 3e-4, **ppo_args}
    model = PPO("CnnPolicy", envs, seed=seed, verbose=0, **settings)
    return model.learn(total_timesteps=timesteps)


def evaluate(model: PPO, episodes: int = 3, seed: int = 1000, **env_kwargs) -> tuple[float, float]:
    """Mean and standard deviation of the return over ``episodes`` deterministic episodes."""
    envs = make_envs(1, seed, subprocesses=False, **env_kwargs)
    try:
        return evaluate_policy(model, envs, n_eval_episodes=episodes, deterministic=True)
    finally:
        envs.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, default=200_000, help="env steps to train")
    parser.add_argument("--envs", type=int, default=4, help="parallel envs")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="ppo_carracing.zip", help="where to save the model")
    args = parser.parse_args()
    model = train(args.timesteps, args.envs, args.seed)
    model.save(Path(args.out))
    mean, std = evaluate(model)
    print(f"saved {args.out}; evaluation return {mean:.1f} ± {std:.1f}")


if __name__ == "__main__":
    main()
