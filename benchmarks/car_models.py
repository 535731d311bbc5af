"""Lap times and steps per second of each car model on each shipped metre track.

Each car model (with a preset where it has them) drives one lap of circuit, autocross and
f1tenth_loop with the centreline driver, from the track's spawn, seed 0. A figure is the
lap's time in simulated seconds (its steps x the sim's step) and the env's steps per
wall-clock second over that lap, the driver's own time excluded. The envs are the shipped
configs with their bird's-eye camera; ``--no-cameras`` leaves the cameras out (a
``state`` sensor instead), so that the car's own cost shows. The rows run one after the
other in one process: compare within a run.

    PYTHONPATH=. python benchmarks/car_models.py [--no-cameras] [--steps 15000]
"""

from __future__ import annotations

import argparse
import subprocess
import time
from typing import Any

import gymnasium as gym
import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.drivers.centerline import CenterlineDriver
from tinyrace.examples import TRACKS_DIR

TRACKS = ("circuit", "autocross", "f1tenth_loop")
CARS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("kinematic_throttle", {"model": "kinematic_throttle"}),
    ("dynamic (1 m/u)", {"model": "dynamic"}),
    ("single_track f1tenth", {"model": "single_track", "preset": "f1tenth"}),
    ("single_track vehicle1", {"model": "single_track", "preset": "vehicle1"}),
    ("single_track vehicle2", {"model": "single_track", "preset": "vehicle2"}),
)


def lap(track: str, car: dict[str, Any], steps: int, cameras: bool) -> tuple[str, float]:
    """(lap time [s] or why there is none, steps per second)."""
    extra: dict[str, Any] = {"sim": {"step_limit": steps}}
    if not cameras:
        extra.update(cameras=[], sensors=[{"id": "motion", "type": "state"}])
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment=str(TRACKS_DIR / track),
        car=car,
        **extra,
    )
    driver = CenterlineDriver()
    observation, info = env.reset(seed=0)
    driver.reset(env)
    stepping = 0.0  # [s] wall time in env.step
    count = 0
    while count < steps:
        count += 1
        action = driver.act(observation, info)
        start = time.perf_counter()
        observation, _, terminated, truncated, info = env.step(action)
        stepping += time.perf_counter() - start
        if terminated or truncated:
            break
    dt = env.unwrapped.dt
    env.close()
    if info.get("lap_finished"):
        result = f"{count * dt:.2f}"
    else:
        result = f"no lap ({info.get('termination') or 'step limit'})"
    return result, count / stepping


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-cameras", action="store_true", help="a state sensor only")
    parser.add_argument("--steps", type=int, default=15000, help="most steps per lap")
    args = parser.parse_args()
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False
    ).stdout.strip()
    print(f"# {time.strftime('%Y-%m-%d', time.gmtime())}, commit {commit}, "
          f"{'no cameras' if args.no_cameras else 'shipped cameras'}")  # fmt: skip
    print("| car | " + " | ".join(f"{t}: lap [s] | steps/s" for t in TRACKS) + " |")
    print("|---|" + "---:|---:|" * len(TRACKS))
    for name, car in CARS:
        cells = []
        for track in TRACKS:
            result, rate = lap(track, car, args.steps, not args.no_cameras)
            cells += [result, f"{rate:.0f}"]
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
