"""Steps/s of two git refs side by side, in one run: ``python benchmarks/compare.py OLD NEW``.

Each ref is checked out into a temporary git worktree; rounds alternate between the two
(OLD, NEW, OLD, NEW, ...) so that load on a shared machine hits both alike. Each round is
a fresh subprocess with ``PYTHONPATH`` set to that ref's checkout, stepping an env with
pre-drawn seeded random actions (resets included when an episode ends). Prints the median
steps/s per ref and case, and NEW/OLD.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# One round in a subprocess: make the env, warm up, time ``steps`` steps; print steps/s.
ROUND = r"""
import json, sys, time
import gymnasium as gym
import numpy as np
import tinyrace
case, steps = sys.argv[1], int(sys.argv[2])
kwargs = json.loads(sys.argv[3])
env = gym.make(case, **kwargs)
env.action_space.seed(0)
actions = [env.action_space.sample() for _ in range(1024)]
env.reset(seed=0)
def run(n):
    for i in range(n):
        _, _, terminated, truncated, _ = env.step(actions[i % len(actions)])
        if terminated or truncated:
            env.reset()
run(200)
start = time.perf_counter()
run(steps)
print(json.dumps(steps / (time.perf_counter() - start)))
"""

CASES = {
    "carracing": ("tinyrace/CarRacing-v0", {}),
    "formula_student": (
        "tinyrace/TinyRace-v0",
        # a bare name: the shipped track wherever the ref keeps it (refs since 70ff527)
        {"environment": "formula_student", "sim": {"step_limit": 10**9}},
    ),
    "f1tenth_loop": (  # a ROS map: walls from its pixels, a car that keeps running into them
        "tinyrace/TinyRace-v0",
        {"environment": "f1tenth_loop", "sim": {"step_limit": 10**9}},
    ),
}


def checkout(ref: str, into: Path) -> Path:
    """A detached worktree of ``ref`` under ``into``."""
    path = into / ref.replace("/", "_")
    subprocess.run(
        ["git", "-C", str(ROOT), "worktree", "add", "--detach", "-f", str(path), ref],
        check=True,
        capture_output=True,
    )
    return path


def one_round(tree: Path, case: str, steps: int) -> float:
    env_id, kwargs = CASES[case]
    done = subprocess.run(
        [sys.executable, "-c", ROUND, env_id, str(steps), json.dumps(kwargs)],
        env={"PYTHONPATH": str(tree), "PATH": "/usr/bin:/bin", "OMP_NUM_THREADS": "1"},
        capture_output=True,
        text=True,
        check=True,
    )
    return float(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old", help="git ref of the baseline")
    parser.add_argument("new", help="git ref to compare")
    parser.add_argument("--rounds", type=int, default=5, help="rounds per ref and case")
    parser.add_argument("--steps", type=int, default=5000, help="timed steps per round")
    parser.add_argument("--case", action="append", choices=sorted(CASES), help="(default: all)")
    args = parser.parse_args(argv)
    cases = args.case or list(CASES)
    with tempfile.TemporaryDirectory(prefix="tinyrace-compare-") as tmp:
        rates = side_by_side(
            args.old,
            args.new,
            Path(tmp),
            cases,
            args.rounds,
            lambda tree, case: one_round(tree, case, args.steps),
        )
    print_table(args.old, args.new, cases, rates, f"median steps/s of {args.rounds}")
    return 0


def side_by_side(
    old: str,
    new: str,
    tmp: Path,
    cases: list[str],
    rounds: int,
    run_round: Callable[[Path, str], float],
) -> dict[tuple[str, str], list[float]]:
    """Each case's rate at both refs, ``rounds`` times, alternating refs within each round
    (so a change of load hits both); the refs' worktrees in ``tmp``, removed after."""
    trees = {ref: checkout(ref, tmp) for ref in (old, new)}
    rates: dict[tuple[str, str], list[float]] = {}
    try:
        for _ in range(rounds):
            for case in cases:
                for ref, tree in trees.items():
                    rates.setdefault((case, ref), []).append(run_round(tree, case))
    finally:
        for tree in trees.values():
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                check=False,
                capture_output=True,
            )
    return rates


def print_table(
    old: str, new: str, cases: list[str], rates: dict[tuple[str, str], list[float]], what: str
) -> None:
    """One row per case: the medians at both refs and their ratio."""
    print(f"{'case':<16} {old:>12} {new:>12}  new/old   ({what})")
    for case in cases:
        before = statistics.median(rates[(case, old)])
        after = statistics.median(rates[(case, new)])
        print(f"{case:<16} {before:>12,.0f} {after:>12,.0f}  {after / before:.3f}")


if __name__ == "__main__":
    raise SystemExit(main())
