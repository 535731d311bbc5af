"""Where an env-step's CPU time goes, N envs stepped together in one process against one env.

Usage::

    python benchmarks/batch_stages.py                  # 8 envs, 4 blocks of 250 steps
    python benchmarks/batch_stages.py --envs 4 --blocks 8

In one process (cv2 on one thread) it makes one ``gym.make("tinyrace/CarRacing-v0")`` env
and ``make_batch(..., N, workers=0)``, warms both up (1,000 steps each by default: a
whole episode), then steps them in alternating blocks (the batch ``--steps`` steps, the
one env N times as many) with the parts of a step timed in place by the thread's CPU
clock: cv2's warp and colour conversion of the ground texture, the car's picture and its
new patches, the dashboard, pymunk's space step, the env's parts (forces, advance,
snapshot, observe, report), and the vector env's own (the slice's step, the
infos' merge, the observations' copy out). Each timer costs a clock read (about a
microsecond) in both alike; nested parts are inside their callers' time. It prints, per
env-step, the sum over all blocks of each (CPU time of the blocks without timers would
be less). Timers are wrappers set on the classes and modules at start: a measurement,
not an API.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

import cv2
import gymnasium as gym
import pymunk
import tinyrace  # noqa: F401  (registers the env ids)
import tinyrace.ground.texture as texture
import tinyrace.vector.env as vector_env
from tinyrace.env import TinyRaceEnv
from tinyrace.sensors.machinery.car_sprite import CarSprite
from tinyrace.sensors.machinery.dashboard import Dashboard
from tinyrace.vector import make_batch
from tinyrace.vector.envslice import EnvSlice
from tinyrace.world.world import World

ENV_ID = "tinyrace/CarRacing-v0"
SECONDS: dict[str, float] = defaultdict(float)  # [s] per timed part, this block
TIMED = {  # class -> its methods timed in place
    CarSprite: ["draw", "_render_patch"],
    Dashboard: ["draw"],
    pymunk.Space: ["step"],
    TinyRaceEnv: ["step", "advance", "snapshot", "observe", "report"],
    World: ["apply_forces"],
    vector_env.BatchVectorEnv: ["step", "_observations_out"],
    EnvSlice: ["step"],
}


def timed(name: str, function: Callable[..., Any]) -> Callable[..., Any]:
    """``function``, its thread CPU time added to ``SECONDS[name]``."""
    clock = time.thread_time

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        began = clock()
        try:
            return function(*args, **kwargs)
        finally:
            SECONDS[name] += clock() - began

    return wrapper


class TimedCv2:
    """cv2 for ``tinyrace.ground.texture``, with the warp and its colour conversion timed."""

    warpAffine = staticmethod(timed("cv2.warpAffine", cv2.warpAffine))  # cv2's names
    cvtColor = staticmethod(timed("cv2.cvtColor", cv2.cvtColor))

    def __getattr__(self, name: str) -> Any:
        return getattr(cv2, name)


def install_timers() -> list[str]:
    """Wrap every timed part; their names, in the order printed."""
    texture.cv2 = TimedCv2()  # type: ignore[attr-defined,assignment]  # a measurement
    names = ["cv2.warpAffine", "cv2.cvtColor"]
    for kind, methods in TIMED.items():
        for method in methods:
            name = f"{kind.__name__}.{method}"
            setattr(kind, method, timed(name, getattr(kind, method)))
            names.append(name)
    vector_env.merge_infos = timed("merge_infos", vector_env.merge_infos)  # type: ignore[assignment]
    return [*names, "merge_infos"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=8, help="envs in the batch")
    parser.add_argument("--blocks", type=int, default=4)
    parser.add_argument("--steps", type=int, default=250, help="batch steps per block")
    parser.add_argument("--warmup", type=int, default=1000, help="steps of each before timing")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    gym.logger.min_level = gym.logger.ERROR
    names = install_timers()
    one, batch = gym.make(ENV_ID), make_batch(ENV_ID, args.envs, workers=0)
    one.action_space.seed(0)
    batch.action_space.seed(0)
    singles = [one.action_space.sample() for _ in range(4096)]
    batches = [batch.action_space.sample() for _ in range(512)]
    one.reset(seed=0)
    batch.reset(seed=1)
    counts = {"one": 0, "batch": 0}

    def run(which: str, steps: int) -> None:
        start = counts[which]
        for index in range(start, start + steps):
            if which == "batch":
                batch.step(batches[index % len(batches)])
                continue
            _, _, terminated, truncated, _ = one.step(singles[index % len(singles)])
            if terminated or truncated:
                one.reset()
        counts[which] = start + steps

    run("one", args.warmup)
    run("batch", args.warmup)
    totals = {which: defaultdict(float) for which in ("one", "batch")}
    for _ in range(args.blocks):
        for which, steps in (("one", args.steps * args.envs), ("batch", args.steps)):
            SECONDS.clear()
            began = time.thread_time()
            run(which, steps)
            totals[which]["CPU, all of it"] += time.thread_time() - began
            for name, seconds in SECONDS.items():
                totals[which][name] += seconds
    env_steps = args.blocks * args.steps * args.envs
    print(f"[µs] thread CPU per env-step: {args.envs} envs in one process against one env")
    print(f"{'part':<36} {'one env':>9} {'batch':>9} {'batch - one':>12}")
    for name in ["CPU, all of it", *names]:
        alone, together = (1e6 * totals[which][name] / env_steps for which in ("one", "batch"))
        print(f"{name:<36} {alone:>9.1f} {together:>9.1f} {together - alone:>12.1f}")
    one.close()
    batch.close()


if __name__ == "__main__":
    main()
