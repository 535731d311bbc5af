"""A plain install's first run and steps/s: what docs/speed.md quotes.

Usage: python benchmarks/first_run.py   (with the interpreter of the install to measure, e.g.
a fresh virtualenv with the wheel; it imports the installed tinyrace, not this checkout)

Each case runs in a new process: import tinyrace, ``gym.make``, reset, 100 random steps, timed
in wall and CPU time, with numba's cache cold (a new ``NUMBA_CACHE_DIR``) and then warm (the
same folder again), for tinyrace/CarRacing-v0 and for a lidar env; then the plain twins
(every ``TINYRACE_*`` variable set to its plain path). Last, steps/s of tinyrace/CarRacing-v0
with random actions on both paths: the best of 5 blocks of 3,000 steps after 500, in wall time
and per CPU-second of the stepping thread (the figure a loaded machine changes least).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

PLAIN = {
    "TINYRACE_LIDAR": "numpy",
    "TINYRACE_PHYSICS": "python",
    "TINYRACE_CONES": "numpy",
    "TINYRACE_DRAWING": "numpy",
    "TINYRACE_TRACE": "python",
}

FIRST_RUN = """
import time
wall, cpu = time.perf_counter(), time.process_time()
import gymnasium as gym
import tinyrace
if {lidar!r}:
    sensors = [{{"id": "lidar", "type": "lidar", "beams": 1080, "fov": 270}}]
    env = gym.make("tinyrace/TinyRace-v0", environment="f1tenth_loop", sensors=sensors)
else:
    env = gym.make("tinyrace/CarRacing-v0")
env.reset(seed=0)
env.action_space.seed(0)
for _ in range(100):
    env.step(env.action_space.sample())
print(time.perf_counter() - wall, time.process_time() - cpu)
"""

STEPS = """
import time
import gymnasium as gym
import numpy as np
import tinyrace
env = gym.make("tinyrace/CarRacing-v0")
env.reset(seed=0)
actions = np.random.default_rng(0).uniform([-1, 0, 0], [1, 1, 1], (15500, 3)).astype(np.float32)
best_wall = best_cpu = 0.0
for block in range(6):
    count = 500 if block == 0 else 3000
    chunk = actions[:count] if block == 0 else actions[500 + 3000 * (block - 1):][:count]
    wall, cpu = time.perf_counter(), time.thread_time()
    for action in chunk:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    if block:
        best_wall = max(best_wall, count / (time.perf_counter() - wall))
        best_cpu = max(best_cpu, count / (time.thread_time() - cpu))
print(best_wall, best_cpu)
"""


def run(code: str, env: dict[str, str]) -> list[float]:
    done = subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        check=True,
        cwd=tempfile.gettempdir(),
    )
    return [float(x) for x in done.stdout.split()]


def main() -> int:
    print(f"{time.strftime('%Y-%m-%d %H:%M')}, load {os.getloadavg()[0]:.1f}, {sys.executable}")
    for lidar in (False, True):
        what = "f1tenth_loop + 1080-beam lidar" if lidar else "tinyrace/CarRacing-v0"
        with tempfile.TemporaryDirectory() as cache:
            for state in ("cold", "warm"):
                wall, cpu = run(FIRST_RUN.format(lidar=lidar), {"NUMBA_CACHE_DIR": cache})
                print(f"{what}, numba's cache {state}: {wall:.2f} s wall, {cpu:.2f} s CPU")
        wall, cpu = run(FIRST_RUN.format(lidar=lidar), PLAIN)
        print(f"{what}, plain twins: {wall:.2f} s wall, {cpu:.2f} s CPU")
    for name, env in (("compiled", {}), ("plain twins", PLAIN)):
        wall, cpu = run(STEPS, env)
        rates = f"{wall:,.0f} steps/s wall, {cpu:,.0f} per CPU-s"
        print(f"tinyrace/CarRacing-v0 steps, {name}: {rates}")
    print(f"load {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
