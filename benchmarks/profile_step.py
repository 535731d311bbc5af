"""Where a step of tinyrace/CarRacing-v0 spends its time.

Usage::

    python benchmarks/profile_step.py                      # 5000 steps, top 25
    python benchmarks/profile_step.py --steps 20000 --top 40
    python benchmarks/profile_step.py --track example_tracks/segmented   # an image track
    python benchmarks/profile_step.py --save step.prof     # for snakeviz / pstats

Steps the env (``gym.make``, wrappers included) with seeded random actions and
profiles ``env.step`` only: the resets that follow an episode's end are not
profiled. Prints the steps/s without the profiler, then, in microseconds per
step, the functions with the most own time, those with the most cumulative time,
and own time summed per source file (C functions by name). cProfile charges
every Python call a little, so many small calls look dearer than they are:
compare the total with the unprofiled figure.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
from pathlib import Path

import gymnasium as gym

from report import print_table
from stepping import Stepper, quiet_gym_warnings

Key = tuple[str, int, str]  # pstats: (file, line, function)


def make_env(track: str | None) -> gym.Env:
    import tinyrace  # noqa: F401  (registers the ids)

    if track is None:
        return gym.make("tinyrace/CarRacing-v0")
    return gym.make("tinyrace/TinyRace-v0", environment=track)


def profile_steps(stepper: Stepper, steps: int) -> tuple[cProfile.Profile, int]:
    """Profile ``steps`` calls of env.step; returns the profile and the resets done."""
    env, actions = stepper.env, stepper.actions
    profiler = cProfile.Profile()
    resets = 0
    for i in range(steps):
        profiler.enable()
        _, _, terminated, truncated, _ = env.step(actions[i % len(actions)])
        profiler.disable()
        if terminated or truncated:
            env.reset()
            resets += 1
    return profiler, resets


def source(key: Key) -> str:
    """A short name for where a function lives: tinyrace/..., a package, or a C function."""
    file, _, function = key
    if file == "~":  # C functions: keep the name, that is the information
        return function.replace("<built-in method ", "<").replace("<method ", "<")
    parts = Path(file).parts
    for package in ("tinyrace", "gymnasium", "pymunk", "numpy", "cv2", "cffi"):
        if package in parts:
            index = len(parts) - 1 - parts[::-1].index(package)
            return "/".join(parts[index:]) if package == "tinyrace" else package
    return Path(file).name


def label(key: Key) -> str:
    file, line, function = key
    return function if file == "~" else f"{source(key)}:{line}:{function}"


def function_rows(stats: dict, steps: int, column: int, top: int) -> list[list[str]]:
    """Top functions by own (column 2) or cumulative (column 3) time, per step."""
    ranked = sorted(stats.items(), key=lambda item: item[1][column], reverse=True)[:top]
    return [
        [
            f"{values[2] / steps * 1e6:.1f}",
            f"{values[3] / steps * 1e6:.1f}",
            f"{values[1] / steps:.1f}",
            label(key),
        ]
        for key, values in ranked
    ]


def source_rows(stats: dict, steps: int, top: int) -> list[list[str]]:
    """Own time summed per source file (or C function), per step."""
    totals: dict[str, list[float]] = {}
    for key, (_, calls, own, _, _) in stats.items():
        total = totals.setdefault(source(key), [0.0, 0.0])
        total[0] += own
        total[1] += calls
    everything = sum(own for own, _ in totals.values())
    ranked = sorted(totals.items(), key=lambda item: item[1][0], reverse=True)[:top]
    return [
        [f"{own / steps * 1e6:.1f}", f"{own / everything:.0%}", f"{calls / steps:.1f}", name]
        for name, (own, calls) in ranked
    ]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000, help="steps to profile")
    parser.add_argument("--top", type=int, default=25, help="rows per table")
    parser.add_argument("--track", help="an image-track folder instead of CarRacing-v0")
    parser.add_argument("--save", type=Path, help="also write the raw profile here")
    args = parser.parse_args(argv)

    with quiet_gym_warnings():
        stepper = Stepper(make_env(args.track))
        stepper.run(0.5)  # warm-up: caches, textures, the env checker's first step
        plain = stepper.run(3.0)
        profiler, resets = profile_steps(stepper, args.steps)
    stats = pstats.Stats(profiler).stats  # type: ignore[attr-defined]
    profiled = sum(values[2] for values in stats.values())
    name = args.track or "tinyrace/CarRacing-v0"
    print(f"{name}: {plain.step_rate:,.0f} steps/s unprofiled ({1e6 / plain.step_rate:.0f} us)")
    print(f"profiled {args.steps} steps ({resets} resets, not profiled): ", end="")
    print(f"{profiled / args.steps * 1e6:.0f} us/step under the profiler")
    headers = ["own us", "cum us", "calls", "function"]
    print_table("Top own time per step", headers, function_rows(stats, args.steps, 2, args.top))
    print_table(
        "Top cumulative time per step", headers, function_rows(stats, args.steps, 3, args.top)
    )
    print_table(
        "Own time per source per step",
        ["own us", "share", "calls", "source"],
        source_rows(stats, args.steps, args.top),
    )
    if args.save:
        profiler.dump_stats(args.save)
        print(f"\nwrote {args.save}")
    stepper.close()


if __name__ == "__main__":
    main()
