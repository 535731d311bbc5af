"""Where the kernel runs the workers of 2 x 8: how often both share one core (Linux).

``python benchmarks/vector_placement.py [--rounds R] [--seconds S]``
steps ``make_batch("tinyrace/CarRacing-v0", 16, workers=2)`` with random actions, the
workers left to the scheduler and pinned to the two cores (``cores=``), in alternating
rounds of S seconds, while a thread of this process reads each worker's state and the
core it last ran on (``/proc/PID/stat``, fields 3 and 39) every 5 ms. It prints per round
the env-steps per second and the share of samples in which both workers were runnable on
the same core (so each had half of it while the other core ran the parent's poll or
nothing), and per half second of the first unpinned round the same two figures: stretches
of both workers on one core, and the rate they cost.

The sampling thread costs the parent some time, so the rates are below
``vector_scale.py``'s; compare the cases within this run.
"""

from __future__ import annotations

import argparse
import os
import statistics
import threading
import time

import gymnasium as gym
import numpy as np

ENV_ID = "tinyrace/CarRacing-v0"
SAMPLE = 0.005  # [s] between two readings of the workers' states
WINDOW = 0.5  # [s] per line of the first unpinned round's timeline


def where(pid: int) -> tuple[str, int]:
    """(state, the core it last ran on) of process ``pid``."""
    with open(f"/proc/{pid}/stat") as stat:
        text = stat.read()
    fields = text[text.rindex(")") + 2 :].split()  # after "pid (name) "
    return fields[0], int(fields[36])


def run(pinned: bool, seconds: float) -> tuple[float, list[tuple[float, bool]], list[float]]:
    """(env-steps/s, samples (time, both workers runnable on one core), step times)."""
    from tinyrace.vector import make_batch

    cores = sorted(os.sched_getaffinity(0))[:2] if pinned else None
    vector = make_batch(ENV_ID, 16, 2, cores=cores)
    pids = [process.pid for process in vector._workers.processes]
    space = gym.spaces.Box(np.array([-1, 0, 0], np.float32), np.array([1, 1, 1], np.float32))
    space.seed(0)
    actions = [np.stack([space.sample() for _ in range(16)]) for _ in range(256)]
    samples: list[tuple[float, bool]] = []
    done = threading.Event()

    def watch() -> None:
        while not done.wait(SAMPLE):
            (state_a, core_a), (state_b, core_b) = where(pids[0]), where(pids[1])
            samples.append((time.perf_counter(), state_a == state_b == "R" and core_a == core_b))

    try:
        vector.reset(seed=0)
        for index in range(50):
            vector.step(actions[index % 256])
        watcher = threading.Thread(target=watch, daemon=True)
        steps, start = 0, time.perf_counter()
        watcher.start()
        times = []
        while time.perf_counter() - start < seconds:
            vector.step(actions[steps % 256])
            steps += 1
            times.append(time.perf_counter())
        done.set()
        watcher.join()
        return steps * 16 / (time.perf_counter() - start), samples, [start, *times]
    finally:
        vector.close()


def timeline(samples: list[tuple[float, bool]], times: list[float]) -> None:
    """Per WINDOW: env-steps/s and the share of samples with both workers on one core."""
    start, end = times[0], times[-1]
    stamps = np.array(times)
    for number in range(int((end - start) / WINDOW)):
        low, high = start + number * WINDOW, start + (number + 1) * WINDOW
        shared = [same for moment, same in samples if low <= moment < high]
        steps = np.count_nonzero((stamps > low) & (stamps <= high))
        span = f"{number * WINDOW:4.1f}-{(number + 1) * WINDOW:.1f} s"
        print(
            f"    {span}: {steps * 16 / WINDOW:7,.0f} env-steps/s, "
            f"both workers on one core in {sum(shared)} of {len(shared)} samples"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=5.0)
    args = parser.parse_args()
    if not os.path.exists(f"/proc/{os.getpid()}/stat") or len(os.sched_getaffinity(0)) < 2:
        raise SystemExit("vector_placement.py needs Linux's /proc and 2 cores")
    import tinyrace  # noqa: F401  (registers the ids)

    print(f"load before: {os.getloadavg()}, cores: {len(os.sched_getaffinity(0))}")
    found: dict[str, list[tuple[float, float]]] = {"unpinned": [], "pinned": []}
    for number in range(args.rounds):
        for case in found:
            rate, samples, times = run(case == "pinned", args.seconds)
            share = sum(same for _, same in samples) / max(len(samples), 1)
            found[case].append((rate, share))
            print(f"round {number + 1} {case:>8}: {rate:7,.0f} env-steps/s, one core {share:.0%}")
            if number == 0 and case == "unpinned":
                timeline(samples, times)
    for case, results in found.items():
        rates, shares = zip(*results, strict=True)
        print(
            f"{case:>8}: median {statistics.median(rates):7,.0f} env-steps/s; both workers on "
            f"one core in {min(shares):.0%}-{max(shares):.0%} of the samples"
        )
    print(f"load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
