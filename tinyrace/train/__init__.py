"""``tinyrace train``: PPO (Stable-Baselines3) on a tinyrace env, evaluated before and after.

Needs the ``train`` extra: ``pip install ".[train]"`` from a clone, or the wheel's path with
``[train]`` inside the quotes (without a GPU, install PyTorch's CPU build first). The env is
the shipped ``f1tenth_lidar`` experiment by default (a lidar and the car's state on the
F1TENTH loop: small vectors that PPO learns to drive in 20,000 steps, seconds on a recent
two-core machine), or the env of any experiment or track (``tinyrace train carracing``:
CarRacing's pixels, a far longer run), found as ``tinyrace run`` finds it. Pixels are
stacked four frames deep; the policy fits the observation: a CNN for an image, one network
per key for a dict, an MLP for a vector::

    tinyrace train                                   # saves ppo_f1tenth_lidar.zip
    tinyrace train carracing --timesteps 200000 --out ppo_carracing.zip

It evaluates the untrained policy, trains with a progress bar (steps, steps/s, the mean
return of recent episodes), saves the model and evaluates it again. Ctrl-C saves the policy
trained so far and exits with 130; SIGTERM (a scheduler's) does the same, exiting with 143.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import gymnasium as gym
from gymnasium import spaces

from tinyrace import __version__
from tinyrace.config.bounds import MAX_TRAIN_ENVS
from tinyrace.errors import ConfigError, Problem
from tinyrace.experiment.files import unmakeable
from tinyrace.train.envs import EnvFailed, _make, raise_failure

if TYPE_CHECKING:
    from stable_baselines3 import PPO
    from stable_baselines3.common.base_class import BaseAlgorithm
    from stable_baselines3.common.vec_env import VecEnv

TINYRACE_ID = "tinyrace/TinyRace-v0"
DEFAULT_TARGET = "f1tenth_lidar"  # the shipped experiment that learns in minutes
TRAIN_EXTRA = (  # the wheel's path, wherever it lies, then [train] inside the quotes
    'pip install ".[train]" (from a clone; from a wheel: pip install '
    f'"path/to/tinyrace-{__version__}-py3-none-any.whl[train]")'
)
FRAMES = 4  # image observations stacked, so that the policy sees speed and turning
PPO_SETTINGS = {"n_steps": 256, "batch_size": 256, "learning_rate": 3e-4}
MIN_STEPS = 16  # the shortest rollout per env (a very short training run)
MAX_TRAIN_SEED = 2**32 - 1  # SB3 seeds numpy's global generator with it (np.random.seed)
MIN_CNN_SIDE = 36  # [px] the smallest image SB3's NatureCNN takes (8/4, 4/2 and 3/1 kernels)
INTERRUPTED = 130  # the exit status after Ctrl-C, as for ``tinyrace run``


@dataclass(frozen=True)
class TrainEnv:
    """Which env to train on: a registered id, its ``gym.make`` arguments, a name."""

    env_id: str
    kwargs: dict[str, Any] = field(default_factory=dict)
    name: str = DEFAULT_TARGET  # the default model file is ppo_<name>.zip


def add_arguments(parser: argparse.ArgumentParser, count: Callable[..., Any]) -> None:
    """``tinyrace train``'s arguments; ``count(low, what[, high])`` parses a whole number from
    low (to high)."""
    parser.add_argument(
        "target",
        nargs="?",
        metavar="NAME_OR_PATH",
        default=DEFAULT_TARGET,
        help="an experiment or track, as run takes it (default: %(default)s, a lidar and "
        "the car's state on the F1TENTH loop; carracing: CarRacing's pixels, far slower)",
    )
    positive = count(1, "a whole number >= 1")
    parser.add_argument(
        "--timesteps", type=positive, default=20_000, help="env steps (default: %(default)s)"
    )
    envs = count(1, f"a whole number from 1 to {MAX_TRAIN_ENVS}", MAX_TRAIN_ENVS)
    parser.add_argument(
        "--envs", type=envs, default=8, help="envs stepped together (default: %(default)s)"
    )
    parser.add_argument(
        "--subprocesses",
        action="store_true",
        help="split the envs into a slice per core, this process stepping one and a worker "
        "process each of the others (default: all in this process, the faster on few cores)",
    )
    parser.add_argument(
        "--seed",
        type=count(
            0,
            f"a whole number from 0 to {MAX_TRAIN_SEED} (numpy's seeds, which SB3 uses)",
            MAX_TRAIN_SEED,
        ),
        default=0,
        help="seeds the envs (env i: seed + i) and the network; evaluation from seed + 1000 "
        "(default: %(default)s)",
    )
    parser.add_argument(
        "--out", help="model file (default: ppo_<name>.zip in this folder, <name> the target's)"
    )
    parser.add_argument(
        "--eval-episodes",
        type=positive,
        default=1,
        help="deterministic episodes whose mean return is printed before and after training "
        "(default: %(default)s; f1tenth_lidar's start is the same every episode)",
    )
    parser.add_argument(
        "--max-episode-steps",
        type=positive,
        help="end every episode after this many steps, training and evaluation (default: "
        "the experiment's max_steps, else its sim.step_limit)",
    )
    parser.add_argument(
        "--force", action="store_true", help="replace an existing model file (default: refuse)"
    )


def model_file(name: str, force: bool) -> Path:
    """``--out`` checked before training: a .zip file path (SB3 adds .zip to any other
    name), not a folder, not an existing file unless ``force``, and never a file that is no
    model (an experiment file called e.zip, a link to one): a model is a zip archive."""
    path = Path(name)
    allowed = None
    if path.suffix != ".zip":
        allowed = "expected a file name ending in .zip"
    elif path.is_dir():
        allowed = "expected a .zip file name, not a folder"
    elif path.is_symlink() and not path.exists():
        allowed = f"expected a file name: this is a link to {os.readlink(path)!r}, which is missing"
    elif path.exists() and not force:
        allowed = "expected a new file name: this one exists (or --force to replace it)"
    elif path.exists() and not zipfile.is_zipfile(path):
        allowed = (
            "expected a new file name or a model to replace: this file is no zip archive "
            "(tinyrace train replaces only models, even with --force)"
        )
    else:
        allowed = unmakeable(path) or _in_track_folder(path, force)
    if allowed is not None:
        raise ConfigError(Problem("<command line>", "--out", name, allowed))
    return path


def _in_track_folder(path: Path, force: bool) -> str | None:
    """A model file inside a track folder is refused unless ``force``, as ``tinyrace run``
    refuses run folders there (a track folder is the user's data, or the installed one)."""
    from tinyrace.validate import track_folder_holding

    try:
        inside = track_folder_holding(path.resolve())
    except (OSError, ValueError):
        return None
    if inside is None or force:
        return None
    return (
        f"expected a file outside the track folder {str(inside)!r} (give another --out, or --force)"
    )


def missing(who: str = "tinyrace train") -> str | None:
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
        f"{who} needs {' and '.join(lacking)}: {TRAIN_EXTRA} "
        "(without a GPU, install PyTorch's CPU build first)"
    )


def train_env(
    target: str | Path | None = DEFAULT_TARGET, max_episode_steps: int | None = None
) -> TrainEnv:
    """The env of ``target`` (an experiment or track, as ``tinyrace run`` takes it; None:
    the default, f1tenth_lidar). Raises ConfigError listing every problem it has."""
    from tinyrace.experiment.target import load_target

    experiment, _ = load_target(target or DEFAULT_TARGET, "NAME_OR_PATH")
    if experiment.is_race:
        allowed = (
            f"a race of {len(experiment.agents)} cars cannot be trained this way: tinyrace "
            "train trains one car; name an experiment or track of one car (a learner among "
            "driven cars: gym.make(..., opponents=[...]); all cars: tinyrace.race.parallel_env)"
        )
        raise ConfigError(Problem("<command line>", "NAME_OR_PATH", str(target), allowed))
    steps = max_episode_steps or experiment.config.max_steps
    limit = {"max_episode_steps": steps} if steps is not None else {}
    chosen = TrainEnv(TINYRACE_ID, {**experiment.env_kwargs, **limit}, experiment.name)
    problem = _untrainable(chosen)
    if problem:
        raise ConfigError(Problem("<command line>", "NAME_OR_PATH", str(target), problem))
    return chosen


def _untrainable(env: TrainEnv) -> str | None:
    """Why PPO cannot train on ``env`` (None if it can): an episode without a step limit
    (the evaluation before training would never end), or a picture smaller than the CNN's
    kernels take."""
    made = gym.make(env.env_id, **env.kwargs)
    try:
        limit = made.spec.max_episode_steps if made.spec is not None else None
        limit = limit or made.unwrapped.config.sim.step_limit  # type: ignore[attr-defined]
        space = made.observation_space
    finally:
        made.close()
    if not limit:
        return (
            "expected episodes that end: this env has no step limit (sim.step_limit: null) and "
            "the experiment no max_steps, so an evaluation episode could run for ever; give "
            "--max-episode-steps N"
        )
    images = space.spaces if isinstance(space, spaces.Dict) else {"observation": space}
    for key, image in images.items():
        shape = image.shape or ()
        if _image(image) and min(shape[:2]) < MIN_CNN_SIDE:
            height, width = shape[:2]
            return (
                f"expected pictures of at least {MIN_CNN_SIDE} x {MIN_CNN_SIDE} px, the "
                f"smallest tinyrace train's CNN (SB3's NatureCNN) takes: {key!r} is "
                f"{width} x {height} px (its camera's resolution)"
            )
    return None


def policy_for(space: spaces.Space[Any]) -> str:
    """SB3's policy for an observation space: CNN for an image, per key for a dict, else MLP."""
    if isinstance(space, spaces.Dict):
        return "MultiInputPolicy"
    if _image(space):
        return "CnnPolicy"
    return "MlpPolicy"


def _image(space: spaces.Space[Any]) -> bool:
    return isinstance(space, spaces.Box) and len(space.shape) == 3 and space.dtype == "uint8"


def has_images(space: spaces.Space[Any]) -> bool:
    """Whether an observation holds a picture (then frames are stacked)."""
    if isinstance(space, spaces.Dict):
        return any(_image(s) for s in space.spaces.values())
    return _image(space)


def ppo_settings(timesteps: int, envs: int) -> dict[str, Any]:
    """PPO's rollout fitted to a short run: never more steps per env than the run has; its
    minibatches the largest that split the rollout evenly (SB3 warns of a short last one)."""
    n_steps = max(MIN_STEPS, min(PPO_SETTINGS["n_steps"], math.ceil(timesteps / envs)))
    rollout = n_steps * envs
    largest = int(PPO_SETTINGS["batch_size"])
    batch_size = max(b for b in range(1, largest + 1) if rollout % b == 0)
    return {**PPO_SETTINGS, "n_steps": n_steps, "batch_size": batch_size}


def trained_steps(timesteps: int, envs: int) -> int:
    """The env steps PPO takes for ``timesteps``: whole rollouts of n_steps x envs."""
    rollout = int(ppo_settings(timesteps, envs)["n_steps"]) * envs
    return math.ceil(timesteps / rollout) * rollout


def vector_env(env: TrainEnv, envs: int, seed: int, subprocesses: bool = False) -> VecEnv:
    """``envs`` copies of the env as one SB3 VecEnv (tinyrace's vector env: a slice of them
    per core, this process stepping one and worker processes the others, when
    ``subprocesses`` and more than one, else all in this process), episode returns
    recorded (VecMonitor)."""
    from stable_baselines3.common.vec_env import VecMonitor

    from tinyrace.sb3 import make_vec_env

    workers = None if subprocesses and envs > 1 else 0
    kwargs = {"env_id": env.env_id, "kwargs": env.kwargs}
    return VecMonitor(make_vec_env(_make, envs, seed=seed, workers=workers, env_kwargs=kwargs))


def make_envs(env: TrainEnv, envs: int, seed: int, subprocesses: bool = False) -> VecEnv:
    """The vector env to train on: pictures stacked ``FRAMES`` deep, vectors as they are."""
    from stable_baselines3.common.vec_env import VecFrameStack

    vec = vector_env(env, envs, seed, subprocesses)
    return VecFrameStack(vec, n_stack=FRAMES) if has_images(vec.observation_space) else vec


class Terminated(KeyboardInterrupt):
    """SIGTERM during training (a cluster's scheduler ending the job): stopped as Ctrl-C is,
    the policy so far saved, exit status 143."""


class _Sigterm:
    """SIGTERM raising Terminated in this (the main) thread while installed; ``received``
    says whether it came (a scheduler signals the whole group: a worker may die of it
    before this process's handler runs)."""

    def __init__(self) -> None:
        self.received = False
        self.previous: Any = None

    def __enter__(self) -> _Sigterm:
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGTERM, self._raise)
        return self

    def __exit__(self, *exc_info: object) -> None:
        if self.previous is not None:
            signal.signal(signal.SIGTERM, self.previous)

    def _raise(self, signum: int, frame: Any) -> None:
        self.received = True
        raise Terminated("SIGTERM")


def new_model(
    env: TrainEnv, envs: int, seed: int, timesteps: int, subprocesses: bool = False
) -> PPO:
    """An untrained PPO agent on ``envs`` copies of ``env`` (its vector env: model.env)."""
    import torch
    from stable_baselines3 import PPO

    vec = make_envs(env, envs, seed, subprocesses)
    try:
        if not has_images(vec.observation_space):
            torch.set_num_threads(1)  # a small MLP: threads cost more than they give
        policy = policy_for(vec.observation_space)
        return PPO(policy, vec, seed=seed, verbose=0, **ppo_settings(timesteps, envs))
    except BaseException:
        close(vec)
        raise


def train(
    env: TrainEnv, timesteps: int, envs: int = 4, seed: int = 0, subprocesses: bool = False
) -> BaseAlgorithm:
    """A PPO agent trained for ``timesteps`` env steps on ``envs`` copies of ``env``."""
    model = new_model(env, envs, seed, timesteps, subprocesses)
    try:
        learn(model, timesteps, progress=False)
    finally:
        close(model.get_env())
    return model


def learn(model: BaseAlgorithm, timesteps: int, progress: bool = True) -> BaseAlgorithm:
    """``model.learn`` with a progress bar (when ``progress``) and env errors raised as
    EnvFailed. Ctrl-C (KeyboardInterrupt) goes through: the model keeps what it learnt."""
    from tinyrace.train.progress import Progress

    rollout = getattr(model, "n_steps", 1) * model.n_envs  # PPO trains whole rollouts
    bar = Progress(math.ceil(timesteps / rollout) * rollout, raise_failure, progress)
    try:
        return model.learn(total_timesteps=timesteps, callback=bar)
    finally:
        bar.close()


def close(vec: VecEnv | None) -> None:
    """Close a vector env; worker processes that do not answer are ended, never waited for."""
    if vec is None:
        return
    inner: Any = getattr(vec, "unwrapped", vec)
    processes = getattr(inner, "processes", [])
    if any(not p.is_alive() for p in processes) or getattr(inner, "waiting", False):
        for process in processes:  # a worker died, or a step was cut off: no goodbyes
            process.terminate()
        inner.closed = True
        return
    vec.close()


def evaluate(model: BaseAlgorithm, env: TrainEnv, episodes: int, seed: int) -> tuple[float, float]:
    """Mean and standard deviation of the return of ``episodes`` deterministic episodes."""
    from stable_baselines3.common.evaluation import evaluate_policy

    vec = make_envs(env, 1, seed, subprocesses=False)
    try:
        result = evaluate_policy(
            model,
            vec,
            n_eval_episodes=episodes,
            deterministic=True,
            callback=lambda local, _: raise_failure([local.get("info")]),
        )
    finally:
        vec.close()
    mean, std = cast(tuple[float, float], result)  # not the per-episode lists: not asked for
    return float(mean), float(std)


def run_command(args: argparse.Namespace) -> int:
    """``tinyrace train``: evaluate, train with a progress bar, save, evaluate again."""
    env = train_env(args.target, args.max_episode_steps)  # its problems before the import
    out = model_file(args.out if args.out is not None else f"ppo_{env.name}.zip", args.force)
    lacking = missing()
    if lacking:
        print(f"tinyrace: error: {lacking}", file=sys.stderr)
        return 2
    trained = trained_steps(args.timesteps, args.envs)
    rollout = ppo_settings(args.timesteps, args.envs)["n_steps"]
    whole = f" ({trained} trained: whole rollouts of {rollout} x {args.envs})"
    asked = f"{args.timesteps} steps{whole if trained != args.timesteps else ''}"
    print(f"tinyrace: PPO on {env.name}: {asked}, {args.envs} envs", flush=True)
    episodes = f"{args.eval_episodes} episode{'s' if args.eval_episodes > 1 else ''}"
    model = new_model(env, args.envs, args.seed, args.timesteps, args.subprocesses)
    sigterm = _Sigterm()
    try:
        with sigterm:
            before = evaluate(model, env, args.eval_episodes, seed=args.seed + 1000)
            print(f"untrained policy: {_returns(before, episodes)}", flush=True)
            learn(model, args.timesteps)
    except EnvFailed as exc:
        print(f"tinyrace: error: {exc}", file=sys.stderr)
        return 1
    except (KeyboardInterrupt, RuntimeError) as exc:  # a worker killed by the group's SIGTERM
        if not isinstance(exc, KeyboardInterrupt) and not sigterm.received:
            raise
        model.save(out)
        by = " by SIGTERM" if sigterm.received else ""
        print(f"interrupted{by} after {model.num_timesteps} steps: saved {out}", file=sys.stderr)
        return 128 + signal.SIGTERM if sigterm.received else INTERRUPTED
    finally:
        close(model.get_env())
    model.save(out)
    print(f"saved {out}")
    after = evaluate(model, env, args.eval_episodes, seed=args.seed + 1000)
    print(f"trained policy:   {_returns(after, episodes)}")
    return 0


def _returns(evaluation: tuple[float, float], episodes: str) -> str:
    mean, std = evaluation
    return f"mean return {mean:.1f} ± {std:.1f} over {episodes} (deterministic)"
