"""The vector env against one in-process env, side by side in one run (issue 37's proxies).

``python benchmarks/vector_scale.py [--rounds R] [--seconds S] [--max-workers W]
[--workers 1,2,4,8,16]``
prints, as medians of R interleaved rounds of S seconds each, env-steps per second and
the ratio to one ``gym.make("tinyrace/CarRacing-v0")`` env stepped in this process:

- ``one_env``: that env, OpenCV as it comes: its thread pool (one thread per core) warps
  each frame in stripes and spins between calls, so the one env keeps about two cores
  busy here (the process's CPU time over the wall time is printed);
- ``one_env_1core``: the same env on one core (``cv2.setNumThreads(1)``, in a fresh
  spawned process): the reference for the rows that add cores (EnvPool's are against its
  one thread, one core). A forked worker, and each ``apart`` process, steps its envs on
  one core as it is: OpenCV's pool does not survive a fork;

- ``in_process_8``: 8 envs stepped together in this process (``workers=0``), per env-step
  (target >= 0.95: an env in a batch costs what it costs alone);
- ``1x1``: 1 env in 1 worker process (target >= 0.7: the round trip is cheap);
- ``Wx8``: W workers x 8 envs for W = 1 .. --max-workers, or each W of ``--workers`` (2 x 8
  on 2 cores: target >= 1.6; on 16 cores, 1, 2, 4, 8, 16 in a few minutes);
- ``Wx8_parent``: W slices of 8 envs, W - 1 stepped by worker processes and one by this
  process itself (``parent_steps=True``) for each W >= 2: W cores' worth of workers with
  no core shared between a worker and a waiting parent;
- ``Wx8_pinned``: ``Wx8`` with worker ``i`` pinned to this process's ``i``-th core (``cores=``,
  Linux), for each W up to the cores: the scheduler cannot put two workers on one core;
- ``apart_Wx8``: W processes that share nothing, each stepping 8 envs in itself
  (``workers=0``), for each W >= 2 of those: what the machine's cores give W x 8 envs with
  no vector env between them (their caches and memory are shared all the same), the
  ceiling of ``Wx8``;
- ``standin_2x64``: 2 workers x 64 stand-in envs that cost nothing (CarRacing's spaces, a
  constant frame): the vector env's own ceiling (target >= 300,000 env-steps/s);
- ``standin_2x64_small``: the same with an observation of 8 floats: the ceiling without the
  frames' bytes (27.6 KB per env and step written by the workers);
- ``standin_2x64_parent``, ``standin_2x64_small_parent``: the same 64 stand-ins in 2 slices,
  1 worker process and this process (``parent_steps=True``);
- ``standin_2x64_pinned``: ``standin_2x64`` with the 2 workers pinned to 2 cores (Linux);
- ``envpool_W``: EnvPool's CarRacing-v3 with W threads x 8 envs, if ``envpool`` imports
  (``pip install envpool`` with its asset packages, in a venv of its own: see
  benchmarks/README.md); else the import's error is printed and the rows are skipped.

Each case's ratios are given twice: its median rate over the one env's median rate, and
the median of the ratios taken round by round (each against the one env of its own round,
stepped seconds before it: the pairing leaves out what the machine did between rounds).

Then each side against its own one: tinyrace's W x 8 against one env on one core (and as
OpenCV comes), EnvPool's W threads against its 1 thread; and the parent's own time per
round of 1x1, 2x8 and the stand-ins, outside waiting for its workers (sending the actions,
collecting the infos, handing out the observations, this loop): the serial part of a step,
which more cores do not hide (issue 37's proxy for many cores).

Every case steps random actions (seeded), after a warm-up, with the garbage of the case
before it collected (``gc.collect``: 8 closed envs left to the collector made the next
case's parent collect them in its loop, 1 x 1 about 7% slower). The machine's load
(``os.getloadavg``) is printed before and after: on a shared machine the figures move. On a
virtual machine (Linux), the share of the cores' time the hypervisor gave to other guests
while a case ran (``steal`` in ``/proc/stat``) is printed per case and round: issue 37 asks
for a quiet machine, and a round with steal is not one.
"""

from __future__ import annotations

import argparse
import functools
import gc
import os
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

ENV_ID = "tinyrace/CarRacing-v0"
WARMUP = 50  # [steps] per case and round, before the clock starts
ACTIONS = 256  # pre-drawn action batches, cycled
# [s] this thread's CPU time per env-step: one env's, and the last vector case's (with
# workers=0, the whole work; robust to a loaded machine, unlike wall time)
CPU: dict[str, list[float]] = {
    "one_env": [],
    "one_env_cores": [],  # the process's CPU time over the wall time (OpenCV's threads)
    "last": [],
    "in_process_8": [],
}
# [s] per round of a vector env with workers: the parent's time outside waiting for them
# (sending, collecting, handing out, this loop): the serial part, which no core count hides
SERIAL: dict[str, list[float]] = {"last": []}
STAT = Path("/proc/stat")


def cpu_ticks() -> tuple[int, int] | None:
    """(steal, all) ticks of every core since boot (``/proc/stat``), None where unread."""
    try:
        fields = [int(f) for f in STAT.read_text().split("\n", 1)[0].split()[1:]]
    except (OSError, ValueError):
        return None
    # user nice system idle iowait irq softirq steal [guest guest_nice, counted in user/nice]
    return fields[7] if len(fields) > 7 else 0, sum(fields[:8])


def steal_share(before: tuple[int, int] | None, after: tuple[int, int] | None) -> float:
    """The share of the cores' time stolen by the hypervisor between two ``cpu_ticks``."""
    if before is None or after is None or after[1] == before[1]:
        return 0.0
    return (after[0] - before[0]) / (after[1] - before[1])


def _actions(num_envs: int) -> list[np.ndarray]:
    space = gym.spaces.Box(np.array([-1, 0, 0], np.float32), np.array([1, 1, 1], np.float32))
    space.seed(0)
    return [np.stack([space.sample() for _ in range(num_envs)]) for _ in range(ACTIONS)]


def rate_single(seconds: float) -> float:
    """Env-steps/s of one gym.make env stepped in this process."""
    import tinyrace  # noqa: F401  (registers the ids)

    env = gym.make(ENV_ID)
    env.reset(seed=0)
    actions = [a[0] for a in _actions(1)]
    steps, start, cpu, process, deadline = 0, 0.0, 0.0, 0.0, None
    while True:
        _, _, terminated, truncated, _ = env.step(actions[steps % ACTIONS])
        if terminated or truncated:
            env.reset()
        steps += 1
        if steps == WARMUP:
            start, cpu, process = time.perf_counter(), time.thread_time(), time.process_time()
            deadline = start + seconds
        if deadline is not None and steps % 16 == 0 and time.perf_counter() > deadline:
            break
    wall = time.perf_counter() - start
    CPU["one_env"].append((time.thread_time() - cpu) / (steps - WARMUP))
    CPU["one_env_cores"].append((time.process_time() - process) / wall)
    env.close()
    return (steps - WARMUP) / wall


def rate_single_one_core(seconds: float) -> float:
    """``rate_single`` on one core: OpenCV's pool off, in a fresh spawned process (a forked
    one would inherit this process's OpenCV state)."""
    import multiprocessing

    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    child = context.Process(target=_single_one_core, args=(queue, seconds))
    child.start()
    rate: float = queue.get()
    child.join()
    return rate


def _single_one_core(queue: Any, seconds: float) -> None:
    import cv2

    cv2.setNumThreads(1)
    queue.put(rate_single(seconds))


def rate_vector(make: Callable[[], Any], num_envs: int, seconds: float, seed: int = 0) -> float:
    """Env-steps/s of a vector env made by ``make`` (closed afterwards)."""
    vector = make()
    try:
        vector.reset(seed=seed * num_envs)
        actions = _actions(num_envs)
        for index in range(WARMUP):
            vector.step(actions[index % ACTIONS])
        waited = _time_waits(vector)
        steps, start, cpu = 0, time.perf_counter(), time.thread_time()
        deadline = start + seconds
        while time.perf_counter() < deadline:
            vector.step(actions[steps % ACTIONS])
            steps += 1
        wall = time.perf_counter() - start
        CPU["last"] = [(time.thread_time() - cpu) / (steps * num_envs)]
        SERIAL["last"] = [(wall - waited[0]) / steps]
        return steps * num_envs / wall
    finally:
        vector.close()


def _time_waits(vector: Any) -> list[float]:
    """A one-item list that adds up the time ``vector`` waits for its workers from now on
    (stays 0 for a vector env without workers)."""
    waited = [0.0]
    workers = getattr(vector, "_workers", None)
    if workers is None or getattr(vector, "_local", None) is not None:
        return waited
    wait_all = workers.wait_all

    def timed() -> None:
        start = time.perf_counter()
        wait_all()
        waited[0] += time.perf_counter() - start

    workers.wait_all = timed
    return waited


def rate_apart(processes: int, seconds: float) -> float:
    """Env-steps/s of ``processes`` processes stepping 8 envs each in themselves, summed."""
    import multiprocessing

    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    children = [
        context.Process(target=_apart, args=(queue, seconds, index)) for index in range(processes)
    ]
    for child in children:
        child.start()
    rates = [queue.get() for _ in children]
    for child in children:
        child.join()
    return float(sum(rates))


def _apart(queue: Any, seconds: float, index: int) -> None:
    from tinyrace.vector import make_batch

    queue.put(rate_vector(functools.partial(make_batch, ENV_ID, 8, 0), 8, seconds, index))


def pinned_cores() -> list[int] | None:
    """This process's cores, for ``cores=`` (None where workers cannot be pinned)."""
    return sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_setaffinity") else None


def standin(
    num_envs: int, workers: int, small: bool = False, parent: bool = False, pin: bool = False
) -> Any:
    from tinyrace.vector import BatchVectorEnv

    from standin import StandIn

    if small:
        observation = gym.spaces.Box(-1.0, 1.0, (8,), np.float32)
    else:
        observation = gym.spaces.Box(0, 255, (96, 96, 3), np.uint8)
    action = gym.spaces.Box(np.array([-1, 0, 0], np.float32), np.array([1, 1, 1], np.float32))
    return BatchVectorEnv(
        [functools.partial(StandIn, 0.0, observation, action)] * num_envs,
        workers,
        parent_steps=parent,
        cores=pinned_cores() if pin else None,
    )


def envpool_case(threads: int) -> tuple[Callable[[], Any], int] | str:
    """EnvPool's CarRacing-v3 with ``threads`` threads x 8 envs, or why it cannot run here."""
    try:
        import envpool
    except Exception as exc:  # not installed, or its assets missing (envpool/atari/roms)
        return f"{type(exc).__name__}: {exc}"
    num_envs = 8 * threads

    def make() -> Any:
        pool = envpool.make(
            "CarRacing-v3",
            env_type="gymnasium",
            num_envs=num_envs,
            batch_size=num_envs,
            num_threads=threads,
            seed=0,
        )
        pool.reset = functools.partial(_envpool_reset, pool.reset)  # seeded at make
        return pool

    return make, num_envs


def _envpool_reset(reset: Callable[[], Any], seed: int | None = None) -> Any:
    return reset()


def cases(counts: list[int]) -> dict[str, tuple[Callable[[float], float], int]]:
    """Name -> (seconds -> env-steps/s, envs per step), in the order printed."""
    from tinyrace.vector import make_batch

    def vector(
        num_envs: int, workers: int, parent: bool = False, cores: list[int] | None = None
    ) -> Callable[[float], float]:
        make = functools.partial(
            make_batch, ENV_ID, num_envs, workers, parent_steps=parent, cores=cores
        )
        return functools.partial(rate_vector, make, num_envs)

    table: dict[str, tuple[Callable[[float], float], int]] = {
        "one_env": (rate_single, 1),
        "one_env_1core": (rate_single_one_core, 1),
        "in_process_8": (vector(8, 0), 8),
        "1x1": (vector(1, 1), 1),
    }
    for workers in counts:
        table[f"{workers}x8"] = (vector(8 * workers, workers), 8 * workers)
    for slices in (w for w in counts if w >= 2):
        table[f"{slices}x8_parent"] = (vector(8 * slices, slices - 1, True), 8 * slices)
    cores = pinned_cores()
    for workers in (w for w in counts if cores is not None and w <= len(cores)):
        table[f"{workers}x8_pinned"] = (vector(8 * workers, workers, cores=cores), 8 * workers)
    for processes in (w for w in counts if w >= 2):
        table[f"apart_{processes}x8"] = (functools.partial(rate_apart, processes), 8 * processes)
    table["standin_2x64"] = (
        functools.partial(rate_vector, functools.partial(standin, 64, 2), 64),
        64,
    )
    table["standin_2x64_small"] = (
        functools.partial(rate_vector, functools.partial(standin, 64, 2, True), 64),
        64,
    )
    if cores is not None and len(cores) >= 2:
        table["standin_2x64_pinned"] = (
            functools.partial(rate_vector, functools.partial(standin, 64, 2, pin=True), 64),
            64,
        )
    for small in (False, True):
        make = functools.partial(standin, 64, 1, small, True)
        name = "standin_2x64_small_parent" if small else "standin_2x64_parent"
        table[name] = (functools.partial(rate_vector, make, 64), 64)
    for threads in counts:
        found = envpool_case(threads)
        if isinstance(found, str):
            print(f"envpool: skipped, it does not import here ({found})")
            break
        make, num_envs = found
        table[f"envpool_{threads}"] = (functools.partial(rate_vector, make, num_envs), num_envs)
    return table


def print_scaling(medians: dict[str, float], counts: list[int]) -> None:
    """Each side against its own one: tinyrace's W x 8 against one env on one core (and as
    OpenCV comes), EnvPool's W threads against its 1 thread (issue 37 quotes 1.74x for
    EnvPool's 2 threads on 2 cores)."""
    one, core, pool = medians["one_env"], medians["one_env_1core"], medians.get("envpool_1")
    for workers in counts:
        rate = medians[f"{workers}x8"]
        line = f"  {workers} x 8: tinyrace {rate / core:5.2f}x its one env on one core "
        line += f"({rate / one:4.2f}x as OpenCV comes)"
        apart = medians.get(f"apart_{workers}x8")
        if apart is not None:
            line += f" ({medians[f'{workers}x8'] / apart:4.2f}x {workers} processes apart)"
        pinned = medians.get(f"{workers}x8_pinned")
        if pinned is not None:
            line += f"; pinned {pinned / core:5.2f}x ({pinned / one:4.2f}x)"
        parent = medians.get(f"{workers}x8_parent")
        if parent is not None:
            line += f"; {workers - 1} + the parent {parent / core:5.2f}x ({parent / one:4.2f}x)"
        if pool is not None:
            threads = medians[f"envpool_{workers}"]
            line += f", EnvPool {threads / pool:5.2f}x its 1 thread, tinyrace/EnvPool "
            line += f"{medians[f'{workers}x8'] / threads:5.2f}x"
        print(line)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--max-workers", type=int, default=os.cpu_count() or 2)
    parser.add_argument("--workers", help="worker counts, comma-separated (default 1..W)")
    args = parser.parse_args()
    counts = (
        sorted({int(w) for w in args.workers.split(",")})
        if args.workers
        else list(range(1, args.max_workers + 1))
    )
    gym.logger.min_level = gym.logger.ERROR
    print(f"load before: {os.getloadavg()}, cores: {os.cpu_count()}", flush=True)
    table = cases(counts)
    serial_cases = {"1x1", "standin_2x64", "standin_2x64_parent", *(f"{w}x8" for w in counts)}
    rates: dict[str, list[float]] = {name: [] for name in table}
    steal: dict[str, list[float]] = {name: [] for name in table}
    for round_ in range(args.rounds):
        for name, (measure, _) in table.items():
            gc.collect()  # the last case's envs, closed: not this case's parent's garbage
            before = cpu_ticks()
            rates[name].append(measure(args.seconds))
            steal[name].append(steal_share(before, cpu_ticks()))
            if name == "in_process_8":
                CPU[name] += CPU["last"]
            if name in serial_cases:
                SERIAL.setdefault(name, []).extend(SERIAL["last"])
        print(
            f"round {round_ + 1}: " + ", ".join(f"{n} {r[-1]:,.0f}" for n, r in rates.items()),
            flush=True,
        )
        print(
            f"  steal in round {round_ + 1}: "
            + ", ".join(f"{n} {s[-1]:.1%}" for n, s in steal.items() if s[-1] > 0)
            + ("(none)" if all(s[-1] == 0 for s in steal.values()) else ""),
            flush=True,
        )
    one, core = (statistics.median(rates[k]) for k in ("one_env", "one_env_1core"))
    print(
        f"\nmedians of {args.rounds} rounds of {args.seconds:g} s (env-steps/s, x one env, "
        "x one env on one core; in brackets the same two ratios taken round by round, each "
        "against the one env of its own round, and their medians):"
    )
    medians = {name: statistics.median(values) for name, values in rates.items()}
    for name, median in medians.items():
        paired = [
            statistics.median(r / o for r, o in zip(rates[name], rates[k], strict=True))
            for k in ("one_env", "one_env_1core")
        ]
        print(
            f"  {name:>18}: {median:>10,.0f}  {median / one:6.2f}x  {median / core:6.2f}x"
            f"  [{paired[0]:.2f}x {paired[1]:.2f}x]"
        )
    print(
        f"  one env kept {statistics.median(CPU['one_env_cores']):.2f} cores busy "
        "(process CPU time / wall time; OpenCV's pool)"
    )
    print_scaling(medians, counts)
    one_cpu, batch_cpu = (statistics.median(CPU[k]) for k in ("one_env", "in_process_8"))
    print(
        f"  CPU per env-step (thread time): one env {one_cpu * 1e6:.0f} us, 8 in process "
        f"{batch_cpu * 1e6:.0f} us: {one_cpu / batch_cpu:.2f}x"
    )
    envs = {"1x1": 1, "standin_2x64": 64, "standin_2x64_parent": 64}
    envs |= {f"{w}x8": 8 * w for w in counts}
    parts = []
    for name, values in SERIAL.items():
        if name != "last":
            serial = statistics.median(values) * 1e6
            own = " with its own slice's step" if name.endswith("_parent") else ""
            parts.append(f"{name} {serial:.0f} us{own} ({serial / envs[name]:.2f} per env-step)")
    print(
        "  the parent's own time per round (outside waiting for the workers): " + ", ".join(parts)
    )
    for suffix, how in (("", "2 workers"), ("_parent", "1 worker and the parent")):
        print(
            f"  the ceiling (stand-ins 2x64, {how}): "
            f"{statistics.median(rates['standin_2x64' + suffix]):,.0f} env-steps/s "
            f"(issue 37: >= 300,000); without the frames' bytes (8-float observations): "
            f"{statistics.median(rates['standin_2x64_small' + suffix]):,.0f}"
        )
    if "standin_2x64_pinned" in rates:
        print(
            "  the ceiling (stand-ins 2x64, 2 workers pinned to 2 cores): "
            f"{statistics.median(rates['standin_2x64_pinned']):,.0f} env-steps/s "
            "(issue 37: >= 300,000)"
        )
    stolen = [share for shares in steal.values() for share in shares]
    print(
        f"  steal (the hypervisor's other guests): {max(stolen):.1%} at most in a case and "
        f"round, {statistics.mean(stolen):.2%} on average; 2 x 8: "
        + ", ".join(f"{share:.1%}" for share in steal.get("2x8", []))
    )
    print(f"load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
