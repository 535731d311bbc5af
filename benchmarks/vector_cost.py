"""The vector env's own cost at two git refs, side by side in one run (issue 37).

``python benchmarks/vector_cost.py OLD NEW [--rounds R] [--seconds S]`` checks both refs
out into temporary worktrees and alternates fresh subprocesses between them, round by
round (so a change of load hits both). Per case it prints the median rate and, from the
same rounds, the CPU time per step of the parent's thread and of the worker processes
(``/proc/<pid>/stat``, Linux; the workers' time includes their polling for the next step):

- ``one_env``: one ``gym.make("tinyrace/CarRacing-v0")`` stepped in the process (steps/s);
- ``1x1``: the same env in one worker (``make_batch(id, 1, workers=1)``; issue 37: >= 0.7x
  ``one_env``);
- ``2x8``: 2 workers x 8 of those envs (issue 37: >= 1.6x ``one_env`` in env-steps/s);
- ``standin_1x1``: 1 stand-in env that costs nothing in 1 worker: the round trip;
- ``standin_2x64``: 2 workers x 64 stand-ins (CarRacing's spaces, a constant 96x96x3
  frame): the vector env's ceiling in env-steps/s (issue 37: >= 300,000);
- ``standin_2x64_views``: the same with ``copy=False`` (observations as views of the
  shared memory): what the parent's copy of 1.8 MB of frames per step costs.

The stand-ins come from this checkout's ``benchmarks/standin.py`` for both refs. The load
average is printed before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from compare import side_by_side

HERE = Path(__file__).resolve().parent

# One round in a subprocess: print {"rate": ..., "parent": ..., "workers": ...}.
ROUND = r"""
import functools, json, multiprocessing, os, sys, time
import gymnasium as gym
import numpy as np
sys.path.insert(0, sys.argv[3])
from standin import StandIn
import tinyrace
from tinyrace.vector import BatchVectorEnv, make_batch
case, seconds = sys.argv[1], float(sys.argv[2])
gym.logger.min_level = gym.logger.ERROR
ID = "tinyrace/CarRacing-v0"
OBS = gym.spaces.Box(0, 255, (96, 96, 3), np.uint8)
ACT = gym.spaces.Box(np.array([-1, 0, 0], np.float32), np.array([1, 1, 1], np.float32))
ACT.seed(0)

def cpu(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
    except OSError:
        return float("nan")
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

def standins(n, workers, copy=True):
    return BatchVectorEnv([functools.partial(StandIn, 0.0, OBS, ACT)] * n, workers, copy=copy)

def measure(step, num_envs, pids):
    for _ in range(50):
        step()
    before = [cpu(p) for p in pids]
    steps, start, thread = 0, time.perf_counter(), time.thread_time()
    while time.perf_counter() - start < seconds:
        step()
        steps += 1
    wall = time.perf_counter() - start
    parent = (time.thread_time() - thread) / steps
    workers = sum(cpu(p) - b for p, b in zip(pids, before)) / steps
    return {"rate": steps * num_envs / wall, "parent": parent, "workers": workers}

if case == "one_env":
    env = gym.make(ID)
    env.reset(seed=0)
    actions = [ACT.sample() for _ in range(256)]
    index = [0]
    def step():
        index[0] += 1
        _, _, terminated, truncated, _ = env.step(actions[index[0] % 256])
        if terminated or truncated:
            env.reset()
    result = measure(step, 1, [])
else:
    num_envs = {"1x1": 1, "standin_1x1": 1, "2x8": 16}.get(case, 64)
    if case == "1x1":
        vector = make_batch(ID, 1, workers=1)
    elif case == "2x8":
        vector = make_batch(ID, 16, workers=2)
    elif case == "standin_1x1":
        vector = standins(1, 1)
    else:
        vector = standins(64, 2, copy=case != "standin_2x64_views")
    vector.reset(seed=0)
    actions = [np.stack([ACT.sample() for _ in range(num_envs)]) for _ in range(64)]
    index = [0]
    def step():
        index[0] += 1
        vector.step(actions[index[0] % 64])
    pids = [p.pid for p in multiprocessing.active_children()]
    result = measure(step, num_envs, pids)
    vector.close()
print(json.dumps(result))
"""

CASES = ["one_env", "1x1", "2x8", "standin_1x1", "standin_2x64", "standin_2x64_views"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old", help="git ref of the baseline")
    parser.add_argument("new", help="git ref to compare")
    parser.add_argument("--rounds", type=int, default=5, help="rounds per ref and case")
    parser.add_argument("--seconds", type=float, default=2.0, help="timed seconds per round")
    parser.add_argument("--case", action="append", choices=CASES, help="(default: all)")
    args = parser.parse_args(argv)
    cases = args.case or CASES
    details: dict[tuple[str, str], list[dict[str, float]]] = {}

    def run_round(tree: Path, case: str) -> float:
        done = subprocess.run(
            [sys.executable, "-c", ROUND, case, str(args.seconds), str(HERE)],
            env={**os.environ, "PYTHONPATH": str(tree)},
            capture_output=True,
            text=True,
            check=True,
        )
        result = json.loads(done.stdout.strip().splitlines()[-1])
        details.setdefault((case, str(tree)), []).append(result)
        return float(result["rate"])

    print(f"load before: {os.getloadavg()}, cores: {os.cpu_count()}", flush=True)
    with tempfile.TemporaryDirectory(prefix="tinyrace-vector-cost-") as tmp:
        rates = side_by_side(args.old, args.new, Path(tmp), cases, args.rounds, run_round)
        trees = {ref: str(Path(tmp) / ref.replace("/", "_")) for ref in (args.old, args.new)}
    print(f"load after: {os.getloadavg()}")
    print(f"\nmedians of {args.rounds} rounds of {args.seconds:g} s; CPU in µs per step")
    print(f"{'case':<20} {'ref':>10} {'rate':>10} {'parent':>8} {'workers':>8}  new/old")
    for case in cases:
        for ref in (args.old, args.new):
            rows = details[(case, trees[ref])]
            parent = statistics.median(r["parent"] for r in rows) * 1e6
            workers = statistics.median(r["workers"] for r in rows) * 1e6
            rate = statistics.median(rates[(case, ref)])
            ratio = rate / statistics.median(rates[(case, args.old)])
            print(
                f"{case:<20} {ref:>10} {rate:>10,.0f} {parent:>8.0f} {workers:>8.0f}  {ratio:.2f}"
            )
    for ref in (args.old, args.new):
        one = statistics.median(rates[("one_env", ref)]) if "one_env" in cases else None
        if one and "1x1" in cases:
            print(f"1x1 / one_env at {ref}: {statistics.median(rates[('1x1', ref)]) / one:.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
