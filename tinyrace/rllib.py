"""Adapters for RLlib (Ray): float pixels, and an env creator every env runner can call.

RLlib's default CNN takes float images, not the uint8 pixels tinyrace's cameras give
(torch: "Input type (unsigned char) and bias type (float) should be the same"), and its
remote env runners make the env in processes of their own, where ``gym.make("tinyrace/...")``
finds no tinyrace ids unless tinyrace was imported there. This module has both parts::

    from ray.tune.registry import register_env
    from tinyrace.rllib import make_env

    register_env("tinyrace", make_env)  # env_config: {"id": ..., gym.make's keywords}

``make_env`` lives in tinyrace, so a worker that unpickles it imports tinyrace (which
registers the ids) before it calls ``gym.make``. ``FloatPixels`` wraps a Gymnasium env,
``FloatPixelsParallel`` a PettingZoo ``ParallelEnv`` (``tinyrace.race.parallel_env``) before
RLlib's ``ParallelPettingZooEnv``; docs/training.md runs both with PPO.

With ``.env_runners(num_envs_per_env_runner=n, gym_env_vectorize_mode="vector_entry_point")``
RLlib's ``SingleAgentEnvRunner`` calls the registered creator once, with ``"num_envs": n``
added to ``env_config``; ``make_env`` then returns the id's vector entry point (tinyrace's
``BatchVectorEnv``, its envs stepped together in the runner's process unless ``"workers"``
says otherwise) in ``FloatPixelsVector``: the runner steps one batch, not n envs in turn.

Neither Ray nor torch is imported here: ``pip install "tinyrace[rllib]"`` installs Ray.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeAlias

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import VectorEnv, VectorObservationWrapper
from gymnasium.vector.utils import batch_space
from pettingzoo import ParallelEnv
from pettingzoo.utils.wrappers import BaseParallelWrapper

from tinyrace.errors import ConfigError, Problem

CARRACING_ID = "tinyrace/CarRacing-v0"
# the key RLlib's vector entry point adds to env_config (SingleAgentEnvRunner.make_env,
# gym_env_vectorize_mode="vector_entry_point": ``entry_point(env_ctx | {"num_envs": n})``)
NUM_ENVS = "num_envs"
WORKERS = "workers"  # the vector entry point's keyword: processes to step the envs in
PIXEL_MAX = 255.0  # uint8 0..255 -> float32 0..1

Observation: TypeAlias = Any  # an array, or a dict of them (a camera dict)


def is_pixels(space: spaces.Space[Any]) -> bool:
    """An image: a uint8 Box of shape (height, width, channels) or (height, width)."""
    return isinstance(space, spaces.Box) and space.dtype == np.uint8 and len(space.shape) in (2, 3)


def float_space(space: spaces.Space[Any]) -> spaces.Space[Any]:
    """``space`` with every image (``is_pixels``) as float32 in [0, 1]: the space itself, or
    the entries of a Dict; any other space as it is."""
    if is_pixels(space):
        assert isinstance(space, spaces.Box)
        return spaces.Box(0.0, 1.0, space.shape, np.float32)
    if isinstance(space, spaces.Dict):
        return spaces.Dict({key: float_space(sub) for key, sub in space.spaces.items()})
    return space


def float_pixels(space: spaces.Space[Any], observation: Observation) -> Observation:
    """One observation of ``space`` with its images as float32 in [0, 1] (``float_space``)."""
    if is_pixels(space):
        return np.asarray(observation, np.float32) / np.float32(PIXEL_MAX)
    if isinstance(space, spaces.Dict):
        return {key: float_pixels(space[key], value) for key, value in observation.items()}
    return observation


class FloatPixels(gym.ObservationWrapper[Any, Any, Any]):
    """A Gymnasium env whose images (uint8, 0..255) are float32 in [0, 1].

    A camera's Box, or each camera of a dict observation; other entries (state, lidar)
    are left as they are. The pixels are divided by 255, nothing else: the network sees
    the same picture, in the dtype RLlib's default CNN takes (a ``format: classes``
    camera's class indices too).
    """

    def __init__(self, env: gym.Env[Any, Any]):
        _expect(env, gym.Env, "a Gymnasium env (gym.make(...))")
        super().__init__(env)
        self._pixels = env.observation_space
        self.observation_space = float_space(env.observation_space)

    def observation(self, observation: Observation) -> Observation:
        return float_pixels(self._pixels, observation)


class FloatPixelsVector(VectorObservationWrapper):
    """A Gymnasium vector env (tinyrace's ``BatchVectorEnv``) whose images are float32 in
    [0, 1]: each env's observation as ``FloatPixels`` makes it, converted for the whole
    batch at once. The single and the batched observation spaces follow."""

    def __init__(self, env: VectorEnv):
        _expect(env, VectorEnv, "a Gymnasium vector env (gym.make_vec(...))")
        super().__init__(env)
        self._pixels = env.single_observation_space
        self.single_observation_space = float_space(self._pixels)
        self.observation_space = batch_space(self.single_observation_space, env.num_envs)

    def observations(self, observations: Observation) -> Observation:
        return float_pixels(self._pixels, observations)  # the single space: the batch's dtype


class FloatPixelsParallel(BaseParallelWrapper):  # type: ignore[misc]  # pettingzoo: untyped
    """A PettingZoo ``ParallelEnv`` (``tinyrace.race.parallel_env(...)``) whose images are
    float32 in [0, 1], each agent's observation as ``FloatPixels`` makes it.

    Everything else (``agents``, ``possible_agents``, ``action_space``, ``render``,
    ``state``, ...) is the wrapped env's, so RLlib's ``ParallelPettingZooEnv`` takes it as
    it takes the env.
    """

    def __init__(self, env: Any):
        _expect(env, ParallelEnv, "a PettingZoo ParallelEnv (tinyrace.race.parallel_env)")
        super().__init__(env)
        self._pixels = {agent: env.observation_space(agent) for agent in env.possible_agents}
        self._float_spaces = {agent: float_space(s) for agent, s in self._pixels.items()}

    def observation_space(self, agent: str) -> spaces.Space[Any]:
        return self._float_spaces[agent]

    def _floats(self, observations: Mapping[str, Observation]) -> dict[str, Observation]:
        return {agent: float_pixels(self._pixels[agent], o) for agent, o in observations.items()}

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Observation], dict[str, Any]]:
        observations, infos = self.env.reset(seed=seed, options=options)
        return self._floats(observations), infos

    def step(self, actions: Mapping[str, Any]) -> tuple[dict[str, Observation], Any, Any, Any, Any]:
        observations, rewards, terminations, truncations, infos = self.env.step(actions)
        return self._floats(observations), rewards, terminations, truncations, infos


def _checked(env_config: object) -> dict[str, Any]:
    """RLlib's env_config as a dict, its ``id`` (if any) text; else a ConfigError."""
    if not isinstance(env_config, Mapping):
        allowed = (
            'expected a dict (RLlib passes its EnvContext), e.g. {"id": "tinyrace/CarRacing-v0"}'
        )
        raise ConfigError(Problem("<RLlib env_config>", "", env_config, allowed))
    config = dict(env_config)
    if not isinstance(config.get("id", CARRACING_ID), str):
        allowed = 'expected an env id, e.g. "tinyrace/CarRacing-v0"'
        raise ConfigError(Problem("<RLlib env_config>", "id", config["id"], allowed))
    return config


def _expect(env: object, kind: type, expected: str) -> None:
    """A TypeError naming what a wrapper takes and what it was given (and the wrapper for
    that), before the wrapper reads an attribute the object lacks."""
    if isinstance(env, kind):
        return
    given = type(env).__name__
    for other, wrapper in _WRAPPERS:
        if other is not kind and isinstance(env, other):
            raise TypeError(f"expected {expected}, got {given}: wrap it in {wrapper}")
    raise TypeError(f"expected {expected}, got {given}")


def make_env(env_config: Mapping[str, Any]) -> gym.Env[Any, Any] | VectorEnv:
    """RLlib's env creator: ``register_env("tinyrace", make_env)``.

    ``env_config["id"]`` is the env's id (default ``tinyrace/CarRacing-v0``); every other
    key goes to ``gym.make`` as a keyword (``max_episode_steps``, ``environment``,
    ``domain_randomize``, ...). The env's images are float32 in [0, 1] (``FloatPixels``).
    RLlib passes an ``EnvContext``: a dict, whose worker index is no key, so it reaches
    no env.

    With ``"num_envs"`` in ``env_config`` (RLlib adds it in ``vector_entry_point`` mode)
    the answer is ``make_vector_env``'s: one vector env of that many envs.
    """
    config = _checked(env_config)
    if NUM_ENVS in config:
        return make_vector_env(config)
    if WORKERS in config:
        allowed = (
            'a keyword of the vector entry point: .env_runners(gym_env_vectorize_mode="vector_'
            'entry_point") makes RLlib ask for a runner\'s envs at once; in "sync" or "async" '
            "mode it asks for one env at a time, which has no workers"
        )
        raise ConfigError(Problem("<RLlib env_config>", WORKERS, config[WORKERS], allowed))
    env_id = config.pop("id", CARRACING_ID)
    return FloatPixels(gym.make(env_id, **config))


def make_vector_env(env_config: Mapping[str, Any]) -> FloatPixelsVector:
    """``env_config["num_envs"]`` envs of ``env_config["id"]`` through the id's vector entry
    point (tinyrace's ``BatchVectorEnv``), images as float32 in [0, 1].

    The other keys go to ``gym.make_vec`` as keywords: the entry point's own (``workers``:
    processes to step the envs in) and each env's (``max_episode_steps``, ...). ``workers``
    defaults to 0, the envs stepped together in the caller's process: an RLlib env runner
    is a process of its own, given one CPU (``num_cpus_per_env_runner``), and the vector
    entry point's default (one process per core) in each runner would crowd the cores.
    """
    config = _checked(env_config)
    if NUM_ENVS not in config:
        allowed = f'expected a dict with "{NUM_ENVS}" (how many envs), e.g. {{"{NUM_ENVS}": 4}}'
        raise ConfigError(Problem("<RLlib env_config>", "", env_config, allowed))
    env_id = config.pop("id", CARRACING_ID)
    num_envs = config.pop(NUM_ENVS)
    config.setdefault(WORKERS, 0)
    vector = gym.make_vec(
        env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **config
    )
    return FloatPixelsVector(vector)


# what each float-pixels wrapper takes, for ``_expect``'s advice
_WRAPPERS: tuple[tuple[type, str], ...] = (
    (gym.Env, "FloatPixels"),
    (VectorEnv, "FloatPixelsVector"),
    (ParallelEnv, "FloatPixelsParallel"),
)

__all__ = [
    "CARRACING_ID",
    "NUM_ENVS",
    "FloatPixels",
    "FloatPixelsParallel",
    "FloatPixelsVector",
    "float_pixels",
    "float_space",
    "is_pixels",
    "make_env",
    "make_vector_env",
]
