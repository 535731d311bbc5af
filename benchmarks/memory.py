"""Memory per env on every shipped track: 1, 4 and 16 envs in one process and in 2 workers.

Each measurement runs in a fresh Python process (nothing shared from an earlier one) with
its own empty cache folder, except where the table says "cache filled": then the folder
holds what a first process wrote. Memory is PSS (``/proc/<pid>/smaps_rollup``: a page
shared by k processes counts 1/k in each), summed over the parent and its worker processes;
RSS is given beside it for one process (there it counts each page once too). The envs are
made with ``gym.make`` (one process) or ``tinyrace.vector.make_batch(..., workers=2)``,
reset, and stepped 5 times with random actions.

    python benchmarks/memory.py              # the table (a few minutes)
    python benchmarks/memory.py --tracks circuit --counts 1 16
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import json
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIDAR = {"cameras": [], "sensors": [{"type": "lidar", "id": "lidar"}]}
# name -> (gym id, kwargs): every shipped track folder, CarRacing, and the circuit's lidar
TRACKS: dict[str, tuple[str, dict[str, object]]] = {
    "carracing": ("tinyrace/CarRacing-v0", {}),
    "autocross": ("tinyrace/TinyRace-v0", {"environment": "autocross"}),
    "carolo_cup": ("tinyrace/TinyRace-v0", {"environment": "carolo_cup"}),
    "circuit": ("tinyrace/TinyRace-v0", {"environment": "circuit"}),
    "circuit (lidar alone)": ("tinyrace/TinyRace-v0", {"environment": "circuit", **LIDAR}),
    "f1tenth_loop": ("tinyrace/TinyRace-v0", {"environment": "f1tenth_loop"}),
    "formula_student": ("tinyrace/TinyRace-v0", {"environment": "formula_student"}),
    "segmented": ("tinyrace/TinyRace-v0", {"environment": "segmented"}),
}
STEPS = 5


def memory(pid: int) -> tuple[float, float]:
    """(PSS, RSS) [MB] of a process."""
    found = {}
    with open(f"/proc/{pid}/smaps_rollup") as rollup:
        for line in rollup:
            parts = line.split()
            if parts[0] in ("Pss:", "Rss:"):
                found[parts[0]] = int(parts[1]) / 1024
    return found["Pss:"], found["Rss:"]


def trimmed(pid: int) -> tuple[float, float]:
    """(PSS, RSS) [MB] of this process after glibc has returned its free blocks (the
    loading of a track leaves some behind; malloc reuses them for the next env)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    return memory(pid)


def one_process(track: str, count: int) -> dict[str, object]:
    """``count`` envs made, reset and stepped in this process, one after the other."""
    import gymnasium as gym
    import tinyrace  # noqa: F401  (registers the ids)

    env_id, kwargs = TRACKS[track]
    before = memory(os.getpid())[0]
    envs, resets = [], []
    for i in range(count):
        start = time.perf_counter()
        env = gym.make(env_id, **kwargs)
        env.reset(seed=i)
        resets.append(time.perf_counter() - start)
        for _ in range(STEPS):
            env.step(env.action_space.sample())
        envs.append(env)
        if i == 0:
            first = memory(os.getpid())
            first_trimmed = trimmed(os.getpid())
    pss, rss = memory(os.getpid())
    return {
        "imports": before,
        "first": first,
        "all": (pss, rss),
        "first trimmed": first_trimmed,
        "all trimmed": trimmed(os.getpid()),
        "resets": resets,
    }


def two_workers(track: str, count: int) -> dict[str, object]:
    """``count`` envs in a 2-worker BatchVectorEnv; PSS of the parent and the workers."""
    import tinyrace  # noqa: F401
    from tinyrace.vector import make_batch

    env_id, kwargs = TRACKS[track]
    start = time.perf_counter()
    envs = make_batch(env_id, count, workers=2, **kwargs)
    envs.reset(seed=0)
    reset = time.perf_counter() - start
    for _ in range(STEPS):
        envs.step(envs.action_space.sample())
    pids = [os.getpid(), *(child.pid for child in multiprocessing.active_children())]
    total = sum(memory(pid)[0] for pid in pids if pid is not None)
    envs.close()
    return {"all": (total, 0.0), "resets": [reset], "processes": len(pids)}


def measure(track: str, count: int, mode: str, cache: str) -> dict[str, object]:
    """One measurement in a fresh process with ``cache`` as its cache folder."""
    environment = {**os.environ, "TINYRACE_CACHE_DIR": cache, "PYTHONPATH": str(ROOT)}
    command = [sys.executable, __file__, "--one", track, str(count), mode]
    done = subprocess.run(command, env=environment, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(done.stderr)
    result: dict[str, object] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def table(tracks: list[str], counts: list[int]) -> None:
    print(
        "| track | envs | one process: PSS (RSS) [MB] | per extra env, raw / trimmed [MB] "
        "| 2 workers: PSS [MB] | reset: first env (empty / filled cache), a later env [s] |"
    )
    print("|---|---|---|---|---|---|")
    for track in tracks:
        with tempfile.TemporaryDirectory(prefix="tinyrace-memory-") as cache:
            cold = measure(track, 1, "process", cache)  # fills the cache folder
            for count in counts:
                alone = measure(track, count, "process", cache)
                workers = measure(track, count, "workers", cache)
                pss, rss = alone["all"]  # type: ignore[misc]
                first_pss = alone["first"][0]  # type: ignore[index]
                extra = (pss - first_pss) / (count - 1) if count > 1 else float("nan")
                trim = alone["all trimmed"][0] - alone["first trimmed"][0]  # type: ignore[index]
                extras = "-" if count == 1 else f"{extra:.1f} / {trim / (count - 1):.1f}"
                resets = alone["resets"]  # type: ignore[index]
                later = f"{resets[-1]:.2f}" if count > 1 else "-"  # type: ignore[index]
                first = f"{cold['resets'][0]:.2f} / {resets[0]:.2f}"  # type: ignore[index]
                print(
                    f"| {track} | {count} | {pss:.0f} ({rss:.0f}) | "
                    f"{extras} | {workers['all'][0]:.0f} | "  # type: ignore[index]
                    f"{first}, {later} |",
                    flush=True,
                )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--tracks", nargs="+", default=list(TRACKS), choices=list(TRACKS))
    parser.add_argument("--counts", nargs="+", type=int, default=[1, 4, 16])
    parser.add_argument("--one", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        track, count, mode = args.one
        run = one_process if mode == "process" else two_workers
        print(json.dumps(run(track, int(count))))
        return
    table(args.tracks, args.counts)


if __name__ == "__main__":
    main()
