"""tinycarlo 1.1's steps/s on track folders; run by run.py in an interpreter that has tinycarlo.

Usage (tinyrace need not be importable here)::

    /tmp/tc/bin/python benchmarks/tinycarlo_steps.py --seconds 2 NAME=FOLDER ...

Steps ``TinyCarloEnv(environment=FOLDER)`` with seeded random steering for the given
time, resetting when an episode ends (as a training loop would), and prints one JSON
line: ``{NAME: {"steps_per_s": ..., "steps": ..., "seconds": ..., "folder": FOLDER}}``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import time

import numpy as np


def steps_per_second(folder: str, seconds: float) -> dict:
    from tinycarlo.env import TinyCarloEnv

    with contextlib.redirect_stdout(io.StringIO()):  # it prints the config file it loaded
        env = TinyCarloEnv(environment=folder)
    if env.step_limit is None:  # tinycarlo 1.1 compares the step count with it
        env.step_limit = 10**9
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1.0, 1.0, (1024, 1))
    env.reset()
    env.step(actions[0])  # warm-up
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        *_, done, _ = env.step(actions[steps % len(actions)])
        steps += 1
        if done:
            env.reset()
    elapsed = time.perf_counter() - start
    return {"steps_per_s": steps / elapsed, "steps": steps, "seconds": elapsed, "folder": folder}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("tracks", nargs="+", help="NAME=FOLDER")
    args = parser.parse_args()
    results = {}
    for item in args.tracks:
        name, folder = item.split("=", 1)
        results[name] = steps_per_second(folder, args.seconds)
    print(json.dumps(results))


if __name__ == "__main__":
    main()
