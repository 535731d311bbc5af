"""2 x 8: env-steps/s and each process's time on a core and in a run queue (Linux).

``python benchmarks/vector_waits.py [--rounds R] [--seconds S] [--variants a,b,...]``
steps ``make_batch("tinyrace/CarRacing-v0", 16, workers=2)`` with random actions in
alternating rounds of S seconds (the order reversed every other round), one variant of how
the two sides wait for each other per case:

- ``polls``: as shipped, the parent polls for the workers' answers (``PARENT_SPIN``) and a
  worker for its next command (``WORKER_SPIN``) before either sleeps;
- ``pinned``: the same, the workers pinned to the two cores (``cores=``);
- ``parent_sleeps``: the parent sleeps on the workers' semaphores at once;
- ``parent_sleeps_worker_2ms``, ``parent_sleeps_worker_5ms``: and the workers poll longer;
- ``both_sleep``: neither polls.

The variants set the modules' constants: a worker's before the workers are forked (the
default start method on Linux), so they inherit it, the parent's for the whole case (it is
read at each wait). Per round it prints
the rate and, for each worker and the parent, the seconds it ran on a core and waited in a
run queue, and its number of times on a core (``/proc/PID/schedstat``): a worker that waits
while it has work shares its core with the other worker or the parent. The hypervisor's
steal over the round is printed too (``vector_scale.cpu_ticks``).
"""

from __future__ import annotations

import argparse
import gc
import os
import statistics
import sys
import time
from pathlib import Path

import gymnasium as gym

sys.path.insert(0, str(Path(__file__).resolve().parent))

import vector_scale

ENV_ID = "tinyrace/CarRacing-v0"
# name -> (the parent's poll [s], a worker's poll [s], workers pinned); None: as shipped
VARIANTS = {
    "polls": (None, None, False),
    "pinned": (None, None, True),
    "parent_sleeps": (0.0, None, False),
    "parent_sleeps_worker_2ms": (0.0, 0.002, False),
    "parent_sleeps_worker_5ms": (0.0, 0.005, False),
    "both_sleep": (0.0, 0.0, False),
}


def schedstat(pid: int) -> tuple[float, float, int]:
    """(seconds on a core, seconds waiting in a run queue, times on a core) of ``pid``."""
    run, wait, slices = Path(f"/proc/{pid}/schedstat").read_text().split()
    return int(run) / 1e9, int(wait) / 1e9, int(slices)


def run(variant: str, seconds: float) -> tuple[float, float, list[tuple[float, float, int]]]:
    """(env-steps/s, steal share, per worker and the parent (run s, wait s, slices))."""
    import tinyrace.vector.link as link
    import tinyrace.vector.worker as worker
    from tinyrace.vector import make_batch

    parent_spin, worker_spin, pinned = VARIANTS[variant]
    shipped = link.PARENT_SPIN, worker.WORKER_SPIN
    link.PARENT_SPIN = shipped[0] if parent_spin is None else parent_spin
    worker.WORKER_SPIN = shipped[1] if worker_spin is None else worker_spin
    gc.collect()
    cores = vector_scale.pinned_cores() if pinned else None
    try:
        vector = make_batch(ENV_ID, 16, 2, cores=cores)
        workers = vector._workers
        try:
            vector.reset(seed=0)
            actions = vector_scale._actions(16)
            for index in range(vector_scale.WARMUP):
                vector.step(actions[index])
            pids = [process.pid for process in workers.processes] + [os.getpid()]
            before, ticks = [schedstat(pid) for pid in pids], vector_scale.cpu_ticks()
            steps, start = 0, time.perf_counter()
            while time.perf_counter() < start + seconds:
                vector.step(actions[steps % vector_scale.ACTIONS])
                steps += 1
            wall = time.perf_counter() - start
            after, stolen = [schedstat(pid) for pid in pids], vector_scale.cpu_ticks()
        finally:
            vector.close()
    finally:
        link.PARENT_SPIN, worker.WORKER_SPIN = shipped
    spent = [(a[0] - b[0], a[1] - b[1], a[2] - b[2]) for a, b in zip(after, before, strict=True)]
    return steps * 16 / wall, vector_scale.steal_share(ticks, stolen), spent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--variants", default="polls,parent_sleeps,pinned")
    args = parser.parse_args()
    names = args.variants.split(",")
    unknown = [name for name in names if name not in VARIANTS]
    if unknown:
        parser.error(f"unknown variants {unknown}; known: {', '.join(VARIANTS)}")
    gym.logger.min_level = gym.logger.ERROR
    print(f"load before: {os.getloadavg()}", flush=True)
    rates: dict[str, list[float]] = {name: [] for name in names}
    for round_ in range(args.rounds):
        for name in names if round_ % 2 == 0 else names[::-1]:
            rate, steal, spent = run(name, args.seconds)
            rates[name].append(rate)
            parts = "; ".join(
                f"{who} {ran:.2f}/{waited:.2f} s {slices}"
                for who, (ran, waited, slices) in zip(
                    ("worker 0", "worker 1", "parent"), spent, strict=True
                )
            )
            print(
                f"round {round_ + 1}: {name:>24} {rate:>8,.0f} env-steps/s, steal {steal:.1%}; "
                f"on a core / in a run queue, times on a core: {parts}",
                flush=True,
            )
    print(f"\nmedians of {args.rounds} rounds of {args.seconds:g} s (env-steps/s):")
    for name, values in rates.items():
        print(
            f"  {name:>24}: {statistics.median(values):>8,.0f} "
            f"({min(values):,.0f}-{max(values):,.0f})"
        )
    print(f"load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
