"""CPU time per env-step of N envs stepped together in one process, against one env.

Usage::

    python benchmarks/batch_cost.py                     # this checkout, 5 rounds
    python benchmarks/batch_cost.py --ref main          # and main's, side by side
    python benchmarks/batch_cost.py --envs 8 --rounds 7 --steps 400

Each round is a fresh subprocess (cv2 and BLAS on one thread) that makes one
``gym.make("tinyrace/CarRacing-v0")`` env and ``make_batch(..., N, workers=0)``, warms
both up (``--warmup`` steps each: every env's caches full, as in training), then times
them in alternating blocks: the batch ``--steps`` steps, the one env ``--steps`` x N
steps, with seeded random actions and resets when an episode ends (the batch's own
autoreset). It prints the thread CPU time and the wall time per env-step of each round
(all its blocks), medians over the rounds, and one env / batch (>= 0.95 is issue 37's
target: an env in a batch costs what it costs alone). The defaults time 1,000 steps per
env of the batch and 8,000 of the one env after 1,000 each: whole episodes (CarRacing's
limit), so both count a reset and its zoom-in (new car pictures) per 1,000 env-steps.
With ``--ref``, rounds alternate between this checkout and a worktree of the ref, so that
the machine's load hits both alike; ``--new REF`` runs a worktree of REF instead of this
checkout.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from compare import checkout

ROOT = Path(__file__).resolve().parents[1]

# One round in a subprocess: per block, [µs] CPU and wall per env-step of (one env, batch).
ROUND = r"""
import json, sys, time
import cv2
import gymnasium as gym
import numpy as np
import tinyrace
from tinyrace.vector import make_batch
cv2.setNumThreads(1)
gym.logger.min_level = gym.logger.ERROR
envs, steps, blocks, warmup = (int(a) for a in sys.argv[1:5])
ENV_ID = "tinyrace/CarRacing-v0"
one = gym.make(ENV_ID)
batch = make_batch(ENV_ID, envs, workers=0)
one.action_space.seed(0)
batch.action_space.seed(0)
singles = [one.action_space.sample() for _ in range(4096)]
batches = [batch.action_space.sample() for _ in range(512)]
one.reset(seed=0)
batch.reset(seed=1)
index = {"one": 0, "batch": 0}
def run_one(n):
    i = index["one"]
    for k in range(i, i + n):
        _, _, terminated, truncated, _ = one.step(singles[k % 4096])
        if terminated or truncated:
            one.reset()
    index["one"] = i + n
def run_batch(n):
    i = index["batch"]
    for k in range(i, i + n):
        batch.step(batches[k % 512])
    index["batch"] = i + n
run_one(warmup)
run_batch(warmup)
rows = []
for block in range(blocks):
    cells = []
    for run, n, per in ((run_one, steps * envs, steps * envs), (run_batch, steps, steps * envs)):
        cpu, wall = time.thread_time(), time.perf_counter()
        run(n)
        cells += [1e6 * (time.thread_time() - cpu) / per, 1e6 * (time.perf_counter() - wall) / per]
    rows.append(cells)
print(json.dumps(rows))
"""


def one_round(tree: Path, envs: int, steps: int, blocks: int, warmup: int) -> list[list[float]]:
    """Per block: [µs] (one env CPU, wall, batch CPU, wall) per env-step, at ``tree``."""
    done = subprocess.run(
        [sys.executable, "-c", ROUND, *(str(v) for v in (envs, steps, blocks, warmup))],
        env={
            "PYTHONPATH": str(tree),
            "PATH": "/usr/bin:/bin",
            "OMP_NUM_THREADS": "1",
            "OPENBLAS_NUM_THREADS": "1",
        },
        capture_output=True,
        text=True,
        check=True,
    )
    rows: list[list[float]] = json.loads(done.stdout.strip().splitlines()[-1])
    return rows


def _totals(blocks: list[list[float]]) -> list[float]:
    """A round's blocks as one: [µs] per env-step over all of them (every block has as
    many env-steps), so that a round of whole episodes counts each zoom-in once."""
    return [statistics.fmean(block[k] for block in blocks) for k in range(4)]


def load() -> str:
    """The machine's 1-minute load average."""
    return Path("/proc/loadavg").read_text().split()[0]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=8, help="envs in the batch")
    parser.add_argument("--rounds", type=int, default=5, help="subprocesses per tree")
    parser.add_argument("--blocks", type=int, default=4, help="timed blocks per round")
    parser.add_argument("--steps", type=int, default=250, help="batch steps per block")
    parser.add_argument("--warmup", type=int, default=1000, help="steps of each before timing")
    parser.add_argument("--ref", help="a git ref to run beside this checkout (e.g. main)")
    parser.add_argument("--new", help="a git ref to run instead of this checkout")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="tinyrace-batch-cost-") as tmp:
        refs = [ref for ref in (args.ref, args.new) if ref]
        made = {ref: checkout(ref, Path(tmp)) for ref in refs}
        trees = {ref: made[ref] for ref in refs if ref == args.ref}
        trees[args.new or "this"] = made[args.new] if args.new else ROOT
        blocks: dict[str, list[list[float]]] = {name: [] for name in trees}
        loads = [load()]
        try:
            for _ in range(args.rounds):
                for name, tree in trees.items():
                    shape = (args.envs, args.steps, args.blocks, args.warmup)
                    blocks[name] += one_round(tree, *shape)
                loads.append(load())
        finally:
            for tree in made.values():
                subprocess.run(
                    ["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                    check=False,
                    capture_output=True,
                )
    print(f"{args.envs} envs in one process against one env; load {'-'.join(loads)}")
    print(f"medians of {args.rounds} rounds of {args.blocks} blocks, [µs] per env-step")
    print(
        f"{'tree':<10} {'one CPU':>9} {'batch CPU':>10} {'ratio':>6} {'one wall':>9} "
        f"{'batch wall':>11} {'ratio':>6}"
    )
    for name, rows in blocks.items():
        rounds = [_totals(rows[k : k + args.blocks]) for k in range(0, len(rows), args.blocks)]
        one_cpu, one_wall, batch_cpu, batch_wall = (
            statistics.median(row[k] for row in rounds) for k in range(4)
        )
        cpu_ratio = statistics.median(row[0] / row[2] for row in rounds)
        wall_ratio = statistics.median(row[1] / row[3] for row in rounds)
        print(
            f"{name:<10} {one_cpu:>9.1f} {batch_cpu:>10.1f} {cpu_ratio:>6.3f} "
            f"{one_wall:>9.1f} {batch_wall:>11.1f} {wall_ratio:>6.3f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
