"""What the observation's warp costs per env-step in a batch of envs, against one env.

Usage::

    python benchmarks/batch_warp.py              # 8 envs, 3 rounds
    python benchmarks/batch_warp.py --envs 16 --rounds 5 --steps 400

In one process it makes the vector entry point with ``--envs`` envs of
tinyrace/CarRacing-v0 (``make_batch(workers=0)``) and one ``gym.make`` env, both with
seeded random actions, and times every cv2 ``warpAffine`` call of the ground textures in
place (wall time, cv2 on one thread). Each round steps the batch ``--steps`` times, then
the one env ``--steps`` x ``--envs`` / 4 times, and prints the wall time per env-step and
per warp of both. The warp is the same work in both (the same size, the same texture
sizes); when it costs more in the batch, the other envs' data has pushed the texture out
of the caches between an env's steps.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
import tinyrace  # noqa: F401  (registers the env ids)
import tinyrace.sensors.texture as texture
from tinyrace.vector import make_batch

from report import print_table

ENV_ID = "tinyrace/CarRacing-v0"
WARMUP = 300  # [steps] of each before the rounds
ACTIONS = 1024  # pre-drawn actions, cycled


class TimedCv2:
    """cv2 for ``tinyrace.sensors.texture``, with its ``warpAffine`` calls timed."""

    def __init__(self) -> None:
        self.seconds, self.calls = 0.0, 0

    def __getattr__(self, name: str) -> Any:
        return getattr(cv2, name)

    def warpAffine(self, *args: Any, **kwargs: Any) -> Any:  # cv2's name
        began = time.perf_counter()
        out = cv2.warpAffine(*args, **kwargs)
        self.seconds += time.perf_counter() - began
        self.calls += 1
        return out

    def take(self) -> float:
        """[µs] per call since the last take."""
        per_call = 1e6 * self.seconds / max(self.calls, 1)
        self.seconds, self.calls = 0.0, 0
        return per_call


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=8, help="envs in the batch")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=500, help="batch steps per round")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    gym.logger.min_level = gym.logger.ERROR
    timed = TimedCv2()
    texture.cv2 = timed  # type: ignore[attr-defined,assignment]  # a measurement, not an API

    space = gym.spaces.Box(np.array([-1, 0, 0], np.float32), np.array([1, 1, 1], np.float32))
    space.seed(0)
    actions = [space.sample() for _ in range(ACTIONS)]
    batches = [np.stack([action] * args.envs) for action in actions]
    vector = make_batch(ENV_ID, args.envs, workers=0)
    vector.reset(seed=0)
    env = gym.make(ENV_ID)
    env.reset(seed=0)

    def step_batch(steps: int) -> float:
        began = time.perf_counter()
        for index in range(steps):
            vector.step(batches[index % ACTIONS])
        return float(1e6 * (time.perf_counter() - began) / (steps * args.envs))

    def step_one(steps: int) -> float:
        began = time.perf_counter()
        for index in range(steps):
            _, _, terminated, truncated, _ = env.step(actions[index % ACTIONS])
            if terminated or truncated:
                env.reset()
        return 1e6 * (time.perf_counter() - began) / steps

    step_batch(WARMUP)
    step_one(WARMUP)
    timed.take()
    rows = []
    for round_index in range(args.rounds):
        batch_step = step_batch(args.steps)
        batch_warp = timed.take()
        one_step = step_one(args.steps * args.envs // 4)
        one_warp = timed.take()
        cells = (batch_step, batch_warp, one_step, one_warp)
        rows.append([str(round_index + 1), *(f"{value:.1f}" for value in cells)])
    print_table(
        f"Wall time [µs]: {args.envs} envs in one process against one gym.make env",
        ["round", "batch: per env-step", "per warp", "one env: per step", "per warp"],
        rows,
    )
    vector.close()
    env.close()


if __name__ == "__main__":
    main()
