"""Soak test: long runs with frequent resets leak neither memory nor pymunk objects.

For each track kind (procedural, and an example image track) this takes 200,000
random in-space steps, resetting about every 1,000 steps (and whenever an
episode ends), and checks:

- resident memory (RSS, from /proc/self/statm, after a garbage collection and
  glibc's malloc_trim; see ``rss``) at the end is within 5% of RSS after a
  warm-up of 50,000 steps that has filled every cache (the render caches and
  the heap's layout settle within about 40,000 steps on the procedural track);
- after every reset the episode's pymunk space holds the same bodies and constraints
  and the same shapes beyond the track's own sensors (procedural tracks differ
  in tile count per seed; an image track's obstacle cells are fixed), and no
  step adds or removes any.

It prints the figures and exits non-zero if a check fails. Not run in CI
(about 30-45 s per track kind):

    python benchmarks/soak.py [--steps 200000] [--reset-every 1000] [--track DIR]
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import os
import resource
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np
import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.examples import TRACKS_DIR

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_TRACK = TRACKS_DIR / "formula_student"
PAGE = os.sysconf("SC_PAGE_SIZE")  # [bytes]
WARMUP = 50_000  # [steps] before the first RSS reading


def _glibc() -> ctypes.CDLL | None:
    try:
        return ctypes.CDLL("libc.so.6")
    except OSError:  # not glibc: RSS is read untrimmed
        return None


LIBC = _glibc()


def rss(trim: bool = True) -> int:
    """[bytes] resident set size now (not the peak), after a full garbage collection.

    ``trim`` first hands the heap's free pages back to the OS (glibc's malloc_trim):
    glibc keeps freed memory in its heap, so that without trimming RSS climbs in steps
    to a plateau set by fragmentation (about +10% over 200,000 steps here) even though
    nothing is live; a leak is live memory, which trimming cannot hand back.
    """
    gc.collect()
    if trim and LIBC is not None:
        LIBC.malloc_trim(0)
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * PAGE


def peak_rss() -> int:
    """[bytes] the process's peak resident set size so far."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


@dataclass
class Soak:
    """The figures of one track kind's run."""

    name: str
    steps: int = 0
    resets: int = 0
    seconds: float = 0.0
    rss_warm: int = 0  # [bytes] after the warm-up, heap trimmed
    rss_end: int = 0  # [bytes] heap trimmed
    untrimmed: tuple[int, int] = (0, 0)  # [bytes] the same two without trimming
    counts: set[tuple[int, int, int]] = field(default_factory=set)  # after each reset, see below
    changed_in_episode: int = 0  # episodes whose space changed its counts while stepping
    problems: list[str] = field(default_factory=list)

    @property
    def growth(self) -> float:
        return self.rss_end / self.rss_warm - 1.0


def space_counts(env: gym.Env) -> tuple[int, int, int]:
    """(bodies, shapes beyond the track's sensors, constraints) of the episode's space."""
    episode = env.unwrapped.episode
    bodies, shapes, constraints = episode.world.counts
    track = episode.track
    test = track.obstacle_test
    sensors = len(track.tiles) if track.tiles is not None else len(test.cells) if test else 0
    return bodies, shapes - sensors, constraints


def soak(name: str, env: gym.Env, steps: int, reset_every: int, warmup: int) -> Soak:
    result = Soak(name)
    space = env.action_space
    rng = np.random.default_rng(0)
    if isinstance(space, gym.spaces.Box):
        actions = list(rng.uniform(space.low, space.high, (4096, *space.shape)).astype(np.float32))
    else:
        actions = list(rng.integers(space.n, size=4096))
    start = time.perf_counter()
    env.reset(seed=0)
    result.counts.add(space_counts(env))
    raw_counts = env.unwrapped.episode.world.counts
    since_reset = 0
    for step in range(steps):
        _, _, terminated, truncated, _ = env.step(actions[step % len(actions)])
        since_reset += 1
        if terminated or truncated or since_reset >= reset_every:
            if env.unwrapped.episode.world.counts != raw_counts:
                result.changed_in_episode += 1
            env.reset()
            result.resets += 1
            since_reset = 0
            result.counts.add(space_counts(env))
            raw_counts = env.unwrapped.episode.world.counts
        if step + 1 == warmup:
            warm_untrimmed, result.rss_warm = rss(trim=False), rss()
    result.steps = steps
    result.seconds = time.perf_counter() - start
    result.untrimmed = (warm_untrimmed, rss(trim=False))
    result.rss_end = rss()
    env.close()
    return result


def judge(result: Soak, tolerance: float) -> None:
    if result.growth >= tolerance:
        result.problems.append(f"RSS grew {result.growth:.1%} (limit {tolerance:.0%})")
    if len(result.counts) != 1:
        result.problems.append(f"space counts differ between resets: {sorted(result.counts)}")
    if result.changed_in_episode:
        result.problems.append(f"{result.changed_in_episode} episodes changed their space")


def report(result: Soak) -> None:
    mib = 1024 * 1024
    (bodies, shapes, constraints), *_ = sorted(result.counts)
    warm, end = result.untrimmed
    print(
        f"{result.name:<16} {result.steps:>8,} steps  {result.resets:>4} resets  "
        f"{result.seconds:7.1f} s  {result.steps / result.seconds:8,.0f} steps/s\n"
        f"{'':<16} RSS after warm-up {result.rss_warm / mib:7.1f} MiB, at the end "
        f"{result.rss_end / mib:7.1f} MiB: {result.growth:+.2%}; peak {peak_rss() / mib:.1f} MiB\n"
        f"{'':<16} (heap untrimmed: {warm / mib:.1f} MiB -> {end / mib:.1f} MiB, "
        f"{end / warm - 1:+.2%})\n"
        f"{'':<16} space after every reset: {bodies} bodies, {shapes} shapes beside the track's "
        f"sensors, {constraints} constraints ({len(result.counts)} distinct)"
    )
    for problem in result.problems:
        print(f"{'':<16} FAIL: {problem}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=200_000, help="steps per track kind")
    parser.add_argument("--reset-every", type=int, default=1000, help="steps between resets")
    parser.add_argument("--warmup", type=int, default=WARMUP, help="steps before the first RSS")
    parser.add_argument("--tolerance", type=float, default=0.05, help="allowed RSS growth")
    parser.add_argument("--track", type=Path, default=DEFAULT_TRACK, help="an image track folder")
    args = parser.parse_args(argv)
    if not args.warmup < args.steps:
        parser.error("--warmup must be smaller than --steps")
    kinds = {
        "procedural": lambda: gym.make("tinyrace/CarRacing-v0"),
        args.track.name: lambda: gym.make("tinyrace/TinyRace-v0", environment=str(args.track)),
    }
    failed = False
    for name, make in kinds.items():
        result = soak(name, make(), args.steps, args.reset_every, args.warmup)
        judge(result, args.tolerance)
        report(result)
        failed |= bool(result.problems)
    print("soak: FAILED" if failed else "soak: passed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
