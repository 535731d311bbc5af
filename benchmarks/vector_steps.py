"""Steps for counting instructions per env-step under callgrind (robust on a loaded machine).

``python benchmarks/vector_steps.py ENVS STEPS``: ``ENVS`` envs of tinyrace/CarRacing-v0
(seeds 0, 1, ...) take 300 warm-up steps, then ``STEPS`` more, all with the same
seeded random actions: ``ENVS > 0`` through the vector entry point in this process
(``make_batch(workers=0)``), ``ENVS <= 0`` as ``max(-ENVS, 1)`` ``gym.make`` envs
stepped one after the other (the same work without the vector env). Run it twice,
with ``STEPS`` = 0 and K, under ``valgrind --tool=callgrind``; instructions per
env-step = (Ir(K) - Ir(0)) / (K * envs).
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np
import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.vector import make_batch

WARMUP = 300  # [steps] before the counted ones
ACTIONS = 1024  # pre-drawn actions, cycled


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("envs", type=int, help="> 0: vector entry point; <= 0: gym.make envs")
    parser.add_argument("steps", type=int, help="steps after the warm-up")
    parser.add_argument(
        "--numpy-from", type=int, default=None, help="make_batch's numpy_from (its default)"
    )
    args = parser.parse_args()
    gym.logger.min_level = gym.logger.ERROR
    space = gym.spaces.Box(np.array([-1, 0, 0], np.float32), np.array([1, 1, 1], np.float32))
    space.seed(0)
    actions = [space.sample() for _ in range(ACTIONS)]
    if args.envs > 0:
        options = {} if args.numpy_from is None else {"numpy_from": args.numpy_from}
        vector = make_batch("tinyrace/CarRacing-v0", args.envs, workers=0, **options)
        batches = [np.stack([action] * args.envs) for action in actions]
        vector.reset(seed=0)
        for index in range(WARMUP + args.steps):
            vector.step(batches[index % ACTIONS])
        return
    envs = [gym.make("tinyrace/CarRacing-v0") for _ in range(max(-args.envs, 1))]
    for seed, env in enumerate(envs):
        env.reset(seed=seed)
    for index in range(WARMUP + args.steps):
        for env in envs:
            _, _, terminated, truncated, _ = env.step(actions[index % ACTIONS])
            if terminated or truncated:
                env.reset()


if __name__ == "__main__":
    main()
