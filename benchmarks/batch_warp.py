"""What the observation's warp costs per env-step in a batch of envs, against one env.

Usage::

    python benchmarks/batch_warp.py              # 8 envs, 3 rounds
    python benchmarks/batch_warp.py --envs 16 --rounds 5 --steps 400

In one process it steps the vector entry point with ``--envs`` envs of
tinyrace/CarRacing-v0 (``make_batch(workers=0)``) and one ``gym.make`` env, as ``run.py``'s
"envs in one process" rows do (the same ``Stepper``: seeded random actions, resets when an
episode ends), and times every cv2 ``warpAffine`` call of the ground textures in place
(wall time, cv2 on one thread). Each round steps the batch ``--steps`` times, then the one
env ``--steps`` x ``--envs`` / 4 times, and prints the wall time per env-step and per warp
of both. The warp is the same work in both (the same size, the same texture sizes); when
it costs more in the batch, the other envs' data has pushed the texture out of the caches
between an env's steps.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import cv2
import gymnasium as gym
import tinyrace  # noqa: F401  (registers the env ids)
import tinyrace.ground.texture as texture
from tinyrace.vector import make_batch

from report import print_table
from stepping import Stepper, quiet_gym_warnings

ENV_ID = "tinyrace/CarRacing-v0"
WARMUP = 300  # [steps] of each before the rounds


class TimedCv2:
    """cv2 for ``tinyrace.ground.texture``, with its ``warpAffine`` calls timed."""

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


def per_step(stepper: Stepper, steps: int) -> float:
    """[µs] wall time per env-step of ``steps`` calls."""
    began = time.perf_counter()
    stepper.take(steps)
    return 1e6 * (time.perf_counter() - began) / (steps * stepper.batch)


def measure(envs: int, rounds: int, steps: int, timed: TimedCv2) -> list[list[str]]:
    """Rows of the table: per round, the batch's and the one env's step and warp [µs]."""
    batch = Stepper(make_batch(ENV_ID, envs, workers=0), batch=envs, auto_reset=True)
    one = Stepper(gym.make(ENV_ID))
    batch.take(WARMUP)
    one.take(WARMUP)
    timed.take()
    rows = []
    for round_index in range(rounds):
        batch_step = per_step(batch, steps)
        batch_warp = timed.take()
        one_step = per_step(one, steps * envs // 4)
        one_warp = timed.take()
        cells = (batch_step, batch_warp, one_step, one_warp)
        rows.append([str(round_index + 1), *(f"{value:.1f}" for value in cells)])
    batch.close()
    one.close()
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=8, help="envs in the batch")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=500, help="batch steps per round")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    timed = TimedCv2()
    texture.cv2 = timed  # type: ignore[attr-defined,assignment]  # a measurement, not an API
    with quiet_gym_warnings():
        rows = measure(args.envs, args.rounds, args.steps, timed)
    print_table(
        f"Wall time [µs]: {args.envs} envs in one process against one gym.make env",
        ["round", "batch: per env-step", "per warp", "one env: per step", "per warp"],
        rows,
    )


if __name__ == "__main__":
    main()
