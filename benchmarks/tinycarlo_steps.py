"""tinycarlo 1.1's steps/s on track folders; run by run.py in an interpreter that has tinycarlo.

Usage (tinyrace need not be importable here)::

    /tmp/tc/bin/python benchmarks/tinycarlo_steps.py --seconds 2 NAME=FOLDER ...

Steps ``TinyCarloEnv(environment=FOLDER)`` with seeded random steering for the given
time and at least ``--min-steps`` steps (200: about 20 s at its speed; fewer steps made its
figure noise), resetting when an episode ends (as a training loop would), resets timed too, and
prints one JSON line: ``{NAME: {"steps_per_s": ..., "steps": ..., "seconds": ...,
"resets": ..., "free": {...}, "folder": FOLDER}}``.

An episode also ends when the car's rear axle leaves the image, as tinyrace's does
(``out_of_bounds``): tinycarlo 1.1 has no such end, and a car driven at random leaves the
image within a few hundred steps and drives on over black ground, where its steps cost a
fraction of those on the track (no obstacle pixels in view); tinyrace's figures never
include such steps. ``free`` holds the figures of tinycarlo's own loop, without that end.

Fairness: tinycarlo is timed in its own loop (no wrappers; tinyrace is timed through
``gym.make``), with the same folders, camera (120x160), seeded random steering and end rule.
The folders run.py passes are tinyrace's examples, whose images (2282-2441 x 1706-1743 px)
are smaller than those of tinycarlo 1.1's own examples in its repository
(formula_student 6000x3000, segmented 4561x3010; not in its wheel). tinycarlo warps the
whole image every step, so its steps/s falls with the image's area (about 5x and 2.5x
slower on its own two than on tinyrace's, measured side by side here), while tinyrace's
stays about the same: the ratio measured on tinyrace's examples is the conservative one.
Pass tinycarlo's own folders as NAME=FOLDER to time those.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import time

import numpy as np


def steps_per_second(folder: str, seconds: float, end_outside: bool, min_steps: int) -> dict:
    """steps/s of one env on ``folder`` over ``seconds`` and at least ``min_steps`` steps;
    ``end_outside``: reset when the car leaves the image."""
    from tinycarlo.env import TinyCarloEnv

    with contextlib.redirect_stdout(io.StringIO()):  # it prints the config file it loaded
        env = TinyCarloEnv(environment=folder)
    if env.step_limit is None:  # tinycarlo 1.1 compares the step count with it
        env.step_limit = 10**9
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1.0, 1.0, (1024, 1))
    env.reset()
    env.step(actions[0])  # warm-up
    env.reset()
    steps = resets = 0
    start = time.perf_counter()
    while time.perf_counter() - start < seconds or steps < min_steps:
        *_, done, _ = env.step(actions[steps % len(actions)])
        steps += 1
        if done or (end_outside and not _inside(env)):
            env.reset()
            resets += 1
    elapsed = time.perf_counter() - start
    return {"steps_per_s": steps / elapsed, "steps": steps, "seconds": elapsed, "resets": resets}


def _inside(env) -> bool:
    """Whether the car's rear axle (its position) is on the image, by tinyrace's rule."""
    rows, cols = env.track.dimensions[env.track.current_track]
    x, y = env.car.position
    return -0.5 <= x < cols - 0.5 and -0.5 <= y < rows - 0.5


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument(
        "--min-steps", type=int, default=200, help="time at least this many steps per track"
    )
    parser.add_argument("tracks", nargs="+", help="NAME=FOLDER")
    args = parser.parse_args()
    results = {}
    for item in args.tracks:
        name, folder = item.split("=", 1)
        results[name] = {
            **steps_per_second(folder, args.seconds, True, args.min_steps),
            "free": steps_per_second(folder, args.seconds, False, args.min_steps),
            "folder": folder,
        }
    print(json.dumps(results))


if __name__ == "__main__":
    main()
