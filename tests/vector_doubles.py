"""Toy envs for the vector env's tests, in a module of their own: a spawn or forkserver worker
unpickles an env class by importing its module, and a test module run under
``--import-mode=importlib`` (CI's sdist stage) is not importable by name in a fresh process,
while this folder is on sys.path (conftest.py) and spawn hands sys.path to its children.
"""

from __future__ import annotations

import gc
import os
import signal

import gymnasium as gym
import numpy as np


class Chatty(gym.Env):
    """Infos that change shape: nested dicts, tuples, numpy scalars, a rare key, a value
    of another type, a string, and envs of one worker that disagree."""

    observation_space = gym.spaces.Box(0.0, 1.0, (2,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return np.zeros(2, np.float32), {"start": True}

    def step(self, action):
        self.t += 1
        value = float(self.np_random.random())
        info = {
            "pose": (value, 2.0 * value, -value),
            "speed": value,
            "steps": self.t,
            "hit": value > 0.5,
            "small": np.float32(value),
            "terms": {"time": -0.1, "tiles": value},
        }
        if self.t % 7 == 0:
            info["rare"] = "a lap"  # not an array: by the pipe
        if self.t % 11 == 0:
            info["steps"] = float(self.t)  # another type: another signature
        if self.t % 5 == 0 and value > 0.7:
            del info["terms"]  # this env differs from the others of its worker
        observation = np.full(2, value, np.float32)
        return observation, value - 0.5, self.t % 17 == 0, self.t % 23 == 0, info


class Doomed(gym.Env):
    """Env 0 of its kind: raises on action > 0.5, is killed by SIGKILL on action < -0.5."""

    observation_space = gym.spaces.Box(0.0, 1.0, (2,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(2, np.float32), {"t": 0}

    def step(self, action):
        if action[0] > 0.5:
            raise KeyError(f"doomed env refused {action[0]:.1f}")
        if action[0] < -0.5:
            os.kill(os.getpid(), signal.SIGKILL)
        return np.full(2, 0.5, np.float32), 1.0, False, False, {"t": 1}


class Blinking(gym.Env):
    """Infos of two shapes taking turns (as CarRacing's reward terms gain a key on the
    steps that reach a tile), with an episode end every 9 steps."""

    observation_space = gym.spaces.Box(0.0, 1.0, (2,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return np.zeros(2, np.float32), {"t": 0}

    def step(self, action):
        self.t += 1
        value = float(self.np_random.random())
        terms = {"time": -0.1, "tiles": value} if self.t % 3 == 0 else {"time": -0.1}
        info = {"t": self.t, "pose": (value, -value), "terms": terms}
        return np.full(2, value, np.float32), value, self.t % 9 == 0, False, info


class Tiles(gym.Env):
    """CarRacing's infos in small: the reward terms gain a key on the steps that reach a
    tile, at random per env, so the envs of one worker disagree on most steps."""

    observation_space = gym.spaces.Box(0.0, 1.0, (2,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return np.zeros(2, np.float32), {"t": 0, "terms": {}}

    def step(self, action):
        self.t += 1
        value = float(self.np_random.random())
        terms = {"time": -0.1, "tiles": value} if value > 0.6 else {"time": -0.1}
        info = {"pose": (value, -value, 0.5), "t": self.t, "on": value > 0.5, "terms": terms}
        return np.full(2, value, np.float32), value, False, self.t % 13 == 0, info


class Still(gym.Env):
    """Two floats observed, one action; resets to zeros with an empty info, its step
    count ``t`` to 0."""

    observation_space = gym.spaces.Box(0.0, 1.0, (2,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return np.zeros(2, np.float32), {}


class NumpyBool(Still):
    """An info value of numpy's bool, which Gymnasium's merge keeps as an object."""

    def step(self, action):
        return np.zeros(2, np.float32), 0.0, False, False, {"b": np.bool_(action[0] > 0)}


class Quiet(Still):
    """An empty info on most steps (as many envs give), a lap count on some, per env."""

    def step(self, action):
        self.t += 1
        value = float(self.np_random.random())
        info = {"lap": self.t} if value > 0.8 else {}
        return np.full(2, value, np.float32), value, False, self.t % 11 == 0, info


class Huge(Still):
    """An info int beyond 64 bits on the third step (no record holds it)."""

    def step(self, action):
        self.t += 1
        return np.zeros(2, np.float32), 0.0, False, False, {"n": 2**70 if self.t == 3 else self.t}


class NoInfo(Still):
    """Returns None for an info on its second step, and from a reset asked for it with
    ``options={"no_info": True}`` (no dict: Gymnasium's merge raises)."""

    def reset(self, *, seed=None, options=None):
        observation, info = super().reset(seed=seed)
        return observation, None if (options or {}).get("no_info") else info

    def step(self, action):
        self.t += 1
        return np.zeros(2, np.float32), 0.0, False, False, None if self.t == 2 else {}


class Heavy(Still):
    """64 KiB observations (a batch of three is handed out over the buffers) that show the
    steps since the reset; raises on an action above 0.5."""

    observation_space = gym.spaces.Box(0.0, 1e6, (16384,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(16384, np.float32), {}

    def step(self, action):
        if action[0] > 0.5:
            raise ValueError(f"heavy env refused action {action[0]:.1f}")
        self.t += 1
        return np.full(16384, self.t, np.float32), 0.0, False, False, {}


class Flags(Still):
    """Episode ends given as numpy's bools, ints and numpy ints on some steps and as plain
    bools on others, at steps that differ from env to env."""

    KINDS = (bool, np.bool_, int, np.int64)

    def step(self, action):
        self.t += 1
        value = float(self.np_random.random())
        kind = self.KINDS[self.t % len(self.KINDS)] if value > 0.3 else bool
        ended = value > 0.9
        return np.full(2, value, np.float32), value, kind(ended), kind(self.t % 13 == 0), {}


class Collector(Still):
    """Tells how many objects its process's collector has frozen (``gc.freeze``)."""

    def frozen(self):
        return gc.get_freeze_count()


LOADED: list[list[int]] = []  # what Lazy loads at its process's first reset


class Lazy(Still):
    """Loads 20,000 objects at its process's first reset, as an env that imports its
    kernels on first use does, and leaves 500 objects in cycles behind at each reset (its
    episode's, garbage once the next episode starts)."""

    LOADS = 20_000

    def reset(self, *, seed=None, options=None):
        if not LOADED:
            LOADED.extend([i] for i in range(self.LOADS))  # lists: the collector tracks them
        episode: dict[str, list[dict]] = {"parts": []}
        episode["parts"].extend({"episode": episode} for _ in range(499))
        self.episode = episode
        return super().reset(seed=seed, options=options)

    def step(self, action):
        return np.zeros(2, np.float32), 0.0, False, False, {}

    def heap(self):
        """(objects the collector tracks and would traverse, objects frozen, whether it
        collects by itself), after a collection."""
        gc.collect()
        return len(gc.get_objects()), gc.get_freeze_count(), gc.isenabled()
