"""A stand-in env that does nothing but spend a set time per step.

Given the time one tinyrace step takes, it shows what a vector env can make of a step
that long on this machine when the env itself costs nothing else: no memory traffic, no
info, one constant observation. Its ``AsyncVectorEnv`` speed-up is the ceiling for any
env with that step time.
"""

from __future__ import annotations

import time
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np


class StandIn(gym.Env):
    """Busy-waits ``step_seconds`` per step (one core, as a CPU-bound step would use)."""

    metadata: ClassVar[dict[str, Any]] = {"render_modes": []}

    def __init__(
        self,
        step_seconds: float,
        observation_space: gym.spaces.Box,
        action_space: gym.Space,
        episode_steps: int = 1000,
    ):
        self.step_seconds = step_seconds
        self.observation_space, self.action_space = observation_space, action_space
        self.episode_steps = episode_steps
        self.observation = np.zeros(observation_space.shape, observation_space.dtype)
        self.steps = 0

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        self.steps = 0
        return self.observation, {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        if self.step_seconds > 0:  # a stand-in that costs nothing reads no clock either
            end = time.perf_counter() + self.step_seconds
            while time.perf_counter() < end:
                pass
        self.steps += 1
        return self.observation, 0.0, False, self.steps >= self.episode_steps, {}
