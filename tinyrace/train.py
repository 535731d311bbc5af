"""``tinyrace train``: PPO (Stable-Baselines3) on a tinyrace env, saved, then evaluated.

Needs the ``train`` extra: ``pip install "tinyrace[train]"`` (without a GPU, install
PyTorch's CPU build first). The env is CarRacing-v0's pixels by default, or the env of an
experiment or track (``tinyrace train formula_student``), found as ``tinyrace run`` finds
it. Pixels are stacked four frames deep; the policy fits the observation: a CNN for an
image, one network per key for a dict of observations, an MLP for a vector::

    tinyrace train --timesteps 200000 --envs 4            # saves ppo_carracing.zip
    python -m tinyrace train formula_student --timesteps 100000 --out fs.zip

It prints the mean return of a few deterministic evaluation episodes at the end.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import gymnasium as gym
from gymnasium import spaces

from tinyrace.config.bounds import MAX_TRAIN_ENVS
from tinyrace.errors import ConfigError, Problem

if TYPE_CHECKING:
    from stable_baselines3.common.base_class import BaseAlgorithm
    from stable_baselines3.common.vec_env import VecEnv

CARRACING_ID = "tinyrace/CarRacing-v0"
TINYRACE_ID = "tinyrace/TinyRace-v0"
TRAIN_EXTRA = 'pip install "tinyrace[train]"'
FRAMES = 4  # observations stacked, so that the policy sees speed and turning
PPO_SETTINGS = {"n_steps": 512, "batch_size": 128, "learning_rate": 3e-4}
MIN_STEPS = 16  # the shortest rollout per env (a very short training run)


@dataclass(frozen=True)
class TrainEnv:
    """Which env to train on: a registered id, its ``gym.make`` arguments, a name."""

    env_id: str
    kwargs: dict[str, Any] = field(default_factory=dict)
    name: str = "carracing"  # the default model file is ppo_<name>.zip


def add_arguments(parser: argparse.ArgumentParser, count: Callable[..., Any]) -> None:
    """``tinyrace train``'s arguments; ``count(low, what[, high])`` parses a whole number from
    low (to high)."""
    parser.add_argument(
        "target",
        nargs="?",
        metavar="NAME_OR_PATH",
        help="an experiment or track, as run takes it (default: CarRacing-v0's pixels)",
    )
    whole, positive = count(0, "a whole number >= 0"), count(1, "a whole number >= 1")
    parser.add_argument("--timesteps", type=positive, default=200_000, help="env steps")
    envs = count(1, f"a whole number from 1 to {MAX_TRAIN_ENVS}", MAX_TRAIN_ENVS)
    parser.add_argument("--envs", type=envs, default=4, help="envs, one process each")
    parser.add_argument(
        "--seed",
        type=whole,
        default=0,
        help="seeds the envs (env i: seed + i) and the network; evaluation from seed + 1000",
    )
    parser.add_argument("--out", help="model file (default: ppo_<name>.zip in this folder)")
    parser.add_argument(
        "--eval-episodes",
        type=positive,
        default=3,
        help="deterministic episodes whose mean return is printed at the end",
    )
    parser.add_argument(
        "--max-episode-steps",
        type=positive,
        help="end every episode after this many steps (training and evaluation)",
    )
    parser.add_argument("--force", action="store_true", help="replace an existing model file")


def model_file(name: str, force: bool) -> Path:
    """``--out`` checked before training: a .zip file path (SB3 adds .zip to any other
    name), not a folder, and not an existing file unless ``force``."""
    path = Path(name)
    allowed = None
    if path.suffix != ".zip":
        allowed = "expected a file name ending in .zip"
    elif path.is_dir():
        allowed = "expected a .zip file name, not a folder"
    elif path.exists() and not force:
        allowed = "expected a new file name: this one exists (or --force to replace it)"
    if allowed is not None:
        raise ConfigError(Problem("<command line>", "--out", name, allowed))
    return path


def missing() -> str | None:
    """What training lacks here (None when stable-baselines3 and torch import): every
    missing package, named as pip knows it."""
    lacking = []
    for module in ("torch", "stable_baselines3"):
        try:
            __import__(module)
        except ImportError:
            lacking.append(module.replace("_", "-"))
    if not lacking:
        return None
    return (
        f"tinyrace train needs {' and '.join(lacking)}: {TRAIN_EXTRA} "
        "(without a GPU, install PyTorch's CPU build first)"
    )


def train_env(target: str | Path | None, max_episode_steps: int | None = None) -> TrainEnv:
    """The env of ``target`` (an experiment or track, as ``tinyrace run`` takes it); None:
    CarRacing-v0. Raises ConfigError listing every problem of the experiment or track."""
    kwargs: dict[str, Any] = {}
    if max_episode_steps is not None:
        kwargs["max_episode_steps"] = max_episode_steps
    if target is None:
        return TrainEnv(CARRACING_ID, kwargs)
    from tinyrace.experiment.target import load_target

    experiment, _ = load_target(target, "NAME_OR_PATH")
    if experiment.is_race:
        allowed = (
            f"a race of {len(experiment.agents)} cars cannot be trained this way: tinyrace "
            "train trains one car; name an experiment or track of one car (a learner among "
            "driven cars: gym.make(..., opponents=[...]); all cars: tinyrace.race.parallel_env)"
        )
        raise ConfigError(Problem("<command line>", "NAME_OR_PATH", str(target), allowed))
    steps = max_episode_steps or experiment.config.max_steps
    limit = {"max_episode_steps": steps} if steps is not None else {}
    return TrainEnv(TINYRACE_ID, {**experiment.env_kwargs, **limit}, experiment.name)


def policy_for(space: spaces.Space[Any]) -> str:
    """SB3's policy for an observation space: CNN for an image, per key for a dict, else MLP."""
    if isinstance(space, spaces.Dict):
        return "MultiInputPolicy"
    if isinstance(space, spaces.Box) and len(space.shape) == 3 and space.dtype == "uint8":
        return "CnnPolicy"
    return "MlpPolicy"


def ppo_settings(timesteps: int, envs: int) -> dict[str, Any]:
    """PPO's rollout fitted to a short run: never more steps per env than the run has."""
    n_steps = max(MIN_STEPS, min(PPO_SETTINGS["n_steps"], math.ceil(timesteps / envs)))
    batch_size = min(PPO_SETTINGS["batch_size"], n_steps * envs)
    return {**PPO_SETTINGS, "n_steps": n_steps, "batch_size": batch_size}


def make_envs(env: TrainEnv, envs: int, seed: int, subprocesses: bool = True) -> VecEnv:
    """``envs`` copies of the env (one process each when ``subprocesses``), frames stacked."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecFrameStack

    vec = make_vec_env(
        _make,
        n_envs=envs,
        seed=seed,
        env_kwargs={"env_id": env.env_id, "kwargs": env.kwargs},
        vec_env_cls=SubprocVecEnv if subprocesses and envs > 1 else None,
    )
    return VecFrameStack(vec, n_stack=FRAMES)


def _make(env_id: str, kwargs: dict[str, Any]) -> gym.Env[Any, Any]:
    """One env (module level, so that worker processes unpickle it and import tinyrace)."""
    import tinyrace  # noqa: F401  (registers the ids in a worker process)

    env = gym.make(env_id, **kwargs)
    if isinstance(env.observation_space, spaces.Dict) and not _flat(env.observation_space):
        return FlatEntries(env)
    return env


def _flat(space: spaces.Dict) -> bool:
    return all(isinstance(s, spaces.Box) for s in space.spaces.values())


class FlatEntries(gym.ObservationWrapper[Any, Any, Any]):
    """A dict observation whose entries are all arrays: each entry that is not a Box (the
    ``cones`` sensor's dict, a count) flattened into one (SB3 takes no nested dicts)."""

    def __init__(self, env: gym.Env[Any, Any]):
        super().__init__(env)
        space = env.observation_space
        assert isinstance(space, spaces.Dict)
        self._nested = {k: s for k, s in space.spaces.items() if not isinstance(s, spaces.Box)}
        self.observation_space = spaces.Dict(
            {
                key: spaces.flatten_space(sub) if key in self._nested else sub
                for key, sub in space.spaces.items()
            }
        )

    def observation(self, observation: dict[str, Any]) -> dict[str, Any]:
        return {
            key: spaces.flatten(self._nested[key], value) if key in self._nested else value
            for key, value in observation.items()
        }


def train(
    env: TrainEnv, timesteps: int, envs: int = 4, seed: int = 0, subprocesses: bool = True
) -> BaseAlgorithm:
    """A PPO agent trained for ``timesteps`` env steps on ``envs`` copies of ``env``."""
    from stable_baselines3 import PPO

    vec = make_envs(env, envs, seed, subprocesses)
    try:
        policy = policy_for(vec.observation_space)
        model = PPO(policy, vec, seed=seed, verbose=0, **ppo_settings(timesteps, envs))
        return model.learn(total_timesteps=timesteps)
    finally:
        vec.close()


def evaluate(model: BaseAlgorithm, env: TrainEnv, episodes: int, seed: int) -> tuple[float, float]:
    """Mean and standard deviation of the return of ``episodes`` deterministic episodes."""
    from stable_baselines3.common.evaluation import evaluate_policy

    vec = make_envs(env, 1, seed, subprocesses=False)
    try:
        result = evaluate_policy(model, vec, n_eval_episodes=episodes, deterministic=True)
    finally:
        vec.close()
    mean, std = cast(tuple[float, float], result)  # not the per-episode lists: not asked for
    return float(mean), float(std)
