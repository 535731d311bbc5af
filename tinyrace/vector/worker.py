"""The worker side of BatchVectorEnv: a process that steps a slice of the envs per message."""

from __future__ import annotations

import os
import pickle
import signal
import time
import traceback
from collections.abc import Callable, Sequence
from multiprocessing.connection import Connection
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium.spaces import Box, Dict
from gymnasium.vector.utils import read_from_shared_memory, write_to_shared_memory

from tinyrace.vector.batched import NUMPY_FROM, BatchStepper

Memory = tuple[Any, gym.Space[Any], int]  # shared buffer, one env's observation space, envs

# [s] a worker polls for its next command this long before it sleeps: waking a sleeping
# process on another core costs 0.1-0.6 ms on a virtual machine, as much as a few env steps
WORKER_SPIN = 0.0005
CLOSED = "closed"  # a worker's last answer
_yield_core = getattr(os, "sched_yield", lambda: time.sleep(0))  # no sched_yield on Windows


class _Slice:
    """One worker's envs: envs ``first``, ``first + 1``, ... of the vector env."""

    def __init__(
        self,
        env_fns: list[Callable[[], gym.Env[Any, Any]]],
        first: int,
        memory: Memory,
        batch_physics: bool = True,
        numpy_from: int = NUMPY_FROM,
    ):
        self.envs = [fn() for fn in env_fns]
        self.first = first
        # dynamic cars: their tyre forces computed together (else each env's own step)
        fits = batch_physics and BatchStepper.fits(self.envs)
        self.batch = BatchStepper(self.envs, numpy_from) if fits else None
        self.buffer, self.space, num_envs = memory
        self.autoreset = np.zeros(len(self.envs), dtype=np.bool_)
        # Boxes (and Dicts of them) are written through views made once: several times
        # faster than write_to_shared_memory, which takes a new view of all memory per call.
        spaces = self.space.values() if isinstance(self.space, Dict) else [self.space]
        plain = all(isinstance(space, Box) for space in spaces)
        self.views = read_from_shared_memory(self.space, self.buffer, num_envs) if plain else None

    def spaces(self) -> list[tuple[gym.Space[Any], gym.Space[Any]]]:
        return [(env.observation_space, env.action_space) for env in self.envs]

    def reset(
        self, seeds: list[int | None], options: dict[str, Any] | None, mask: np.ndarray
    ) -> list[dict[str, Any] | None]:
        infos: list[dict[str, Any] | None] = []
        for j, env in enumerate(self.envs):
            if not mask[j]:
                infos.append(None)
                continue
            observation, info = env.reset(seed=seeds[j], options=options)
            self._write(j, observation)
            self.autoreset[j] = False
            infos.append(info)
        self._invalidate()
        return infos

    def step(
        self, actions: Any
    ) -> tuple[list[SupportsFloat], list[bool], list[bool], list[dict[str, Any]]]:
        """Step every env (an env whose episode ended at the last step is reset instead):
        rewards, terminations, truncations and infos, as lists (they pickle faster)."""
        n = len(self.envs)
        autoreset = self.autoreset
        if self.batch is not None:
            results = self.batch.step(actions, autoreset, self._write)
        else:
            results = [
                None if autoreset[j] else env.step(actions[j]) for j, env in enumerate(self.envs)
            ]
        rewards: list[SupportsFloat] = [0.0] * n
        terminated, truncated = [False] * n, [False] * n
        infos: list[dict[str, Any]] = [{}] * n
        for j, result in enumerate(results):
            if result is None:  # the episode ended at the last step: reset, reward 0, not done
                observation, infos[j] = self.envs[j].reset()
                self._write(j, observation)
                continue
            observation, rewards[j], terminated[j], truncated[j], infos[j] = result
            if self.batch is None:
                self._write(j, observation)
        # cast by numpy as SyncVectorEnv's arrays are (a step may return numpy scalars)
        ended = np.array(terminated, dtype=np.bool_) | np.array(truncated, dtype=np.bool_)
        self.autoreset = ended
        return rewards, terminated, truncated, infos

    def call(self, name: str, args: tuple[Any, ...], kwargs: dict[str, Any]) -> list[Any]:
        results = []
        for env in self.envs:
            attribute = env.get_wrapper_attr(name)
            results.append(attribute(*args, **kwargs) if callable(attribute) else attribute)
        self._invalidate()
        return results

    def set_attr(self, name: str, values: Sequence[Any]) -> None:
        for env, value in zip(self.envs, values, strict=True):
            env.set_wrapper_attr(name, value)
        self._invalidate()

    def _invalidate(self) -> None:
        """The envs may have changed (reset, called, set): the batch reloads its cars."""
        if self.batch is not None:
            self.batch.invalidate()

    def close(self) -> None:
        for env in self.envs:
            env.close()

    def _write(self, j: int, observation: Any) -> None:
        index = self.first + j
        if self.views is None:
            write_to_shared_memory(self.space, index, observation, self.buffer)
        elif isinstance(self.views, dict):
            for key, view in self.views.items():
                view[index] = observation[key]
        else:
            self.views[index] = observation  # type: ignore[index]  # a Box: one array


def work(
    pipe: Connection,
    parent: Connection,
    env_fns: list[Callable[[], gym.Env[Any, Any]]],
    first: int,
    memory: Memory,
    batch_physics: bool = True,
    numpy_from: int = NUMPY_FROM,
) -> None:
    """A worker's loop: build the envs, then answer ``(command, args)`` until "close"."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    parent.close()
    try:
        envs = _Slice(env_fns, first, memory, batch_physics, numpy_from)
    except Exception as error:
        pipe.send((False, _describe(error)))
        return
    pipe.send((True, envs.spaces()))
    while True:
        _poll(pipe, WORKER_SPIN)
        try:
            command, args = pipe.recv()
        except EOFError:  # the parent is gone
            break
        if command == "close":
            envs.close()
            pipe.send((True, CLOSED))
            break
        try:
            pipe.send((True, getattr(envs, command)(*args)))
        except Exception as error:
            pipe.send((False, _describe(error)))


def _poll(pipe: Connection, seconds: float) -> None:
    """Return when ``pipe`` has data or after ``seconds``, yielding the core meanwhile."""
    deadline = time.perf_counter() + seconds
    while not pipe.poll() and time.perf_counter() < deadline:
        _yield_core()


def _describe(error: Exception) -> tuple[str, str, str, bytes | None]:
    """(type name, message, traceback text, the pickled exception or None)."""
    try:
        pickled: bytes | None = pickle.dumps(error)
    except Exception:
        pickled = None
    return type(error).__name__, str(error), traceback.format_exc(), pickled
