"""Instructions per step of two git refs, under valgrind: ``python benchmarks/step_instructions.py
OLD NEW``.

The cases and the stepping of ``compare.py`` (seeded random actions, resets included, 200
steps of warm-up), each run under ``valgrind --tool=cachegrind`` twice per ref: with no
timed steps and with ``--steps``; the difference over ``--steps`` is one step's cost,
without the start-up. Instruction counts (and, with ``--cache-sim``, simulated cache
misses and branch mispredictions) do not depend on the machine's load, unlike
``compare.py``'s rates: they tell a change of work apart from a busy machine, though not
every change of time (a real cache, the threads' waits). The runs go in parallel, one per
core.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from compare import CASES, ROOT, ROUND, checkout

# compare.py's round with the timing left out: warm-up and ``steps`` more steps
STEPS = ROUND.split("start = time.perf_counter()")[0] + "run(steps)\n"
COUNTS = {  # cachegrind's summary lines: what each counts
    "instructions": r"I\s+refs:\s+([\d,]+)",
    "D1 misses": r"D1\s+misses:\s+([\d,]+)",
    "LL misses": r"LL misses:\s+([\d,]+)",
    "mispredicts": r"Mispredicts:\s+([\d,]+)",
}


def counts(tree: Path, case: str, steps: int, cache_sim: bool) -> dict[str, int]:
    """Cachegrind's totals for ``steps`` steps of ``case`` at ``tree`` (start-up included)."""
    env_id, kwargs = CASES[case]
    sims = ["--cache-sim=yes", "--branch-sim=yes"] if cache_sim else []
    command = ["valgrind", "--tool=cachegrind", "--cachegrind-out-file=/dev/null", *sims]
    command += [sys.executable, "-c", STEPS, env_id, str(steps), json.dumps(kwargs)]
    done = subprocess.run(command, env=_environ(tree), capture_output=True)
    text = done.stderr.decode(errors="replace")
    if done.returncode != 0:
        raise RuntimeError(f"valgrind failed at {tree} ({case}):\n{text[-2000:]}")
    found = {}
    for name, pattern in COUNTS.items():
        match = re.search(pattern, text)
        if match:
            found[name] = int(match.group(1).replace(",", ""))
    return found


def _environ(tree: Path) -> dict[str, str]:
    """The subprocess's environment: ``tree``'s code, one OpenMP thread, fixed str hashes."""
    path = os.environ.get("PATH", "/usr/bin:/bin")
    return {"PYTHONPATH": str(tree), "PATH": path, "OMP_NUM_THREADS": "1", "PYTHONHASHSEED": "0"}


def warm(tree: Path, case: str) -> None:
    """One run without valgrind, so that the counted runs find the track cache filled (a
    first run hashes and writes the track's arrays: start-up work that differs by run)."""
    env_id, kwargs = CASES[case]
    command = [sys.executable, "-c", STEPS, env_id, "0", json.dumps(kwargs)]
    subprocess.run(command, env=_environ(tree), capture_output=True, check=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old", help="git ref of the baseline")
    parser.add_argument("new", help="git ref to compare")
    parser.add_argument("--steps", type=int, default=1000, help="counted steps per ref")
    parser.add_argument("--case", action="append", choices=sorted(CASES), help="(default: all)")
    parser.add_argument("--cache-sim", action="store_true", help="also cache and branch sims")
    args = parser.parse_args(argv)
    if shutil.which("valgrind") is None:
        parser.error("valgrind is not installed (apt-get install valgrind)")
    cases = args.case or list(CASES)
    with tempfile.TemporaryDirectory(prefix="tinyrace-instructions-") as tmp:
        trees = {ref: checkout(ref, Path(tmp)) for ref in (args.old, args.new)}
        jobs = [(ref, case, n) for case in cases for ref in trees for n in (0, args.steps)]
        try:
            for ref, case, _ in jobs[::2]:
                warm(trees[ref], case)
            with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
                runs = pool.map(
                    lambda job: counts(trees[job[0]], job[1], job[2], args.cache_sim), jobs
                )
                totals = dict(zip(jobs, runs, strict=True))
        finally:
            for tree in trees.values():
                subprocess.run(
                    ["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                    check=False,
                )
    print(f"{'case':<16} {'per step':<13} {args.old:>12} {args.new:>12}  new/old")
    for case in cases:
        for name in totals[(args.old, case, 0)]:
            old, new = (
                (totals[(ref, case, args.steps)][name] - totals[(ref, case, 0)][name]) / args.steps
                for ref in (args.old, args.new)
            )
            ratio = f"{new / old:.4f}" if old >= 100 else "(too few to compare)"
            if old < 0 or new < 0:  # one run's start-up did more (a cache built, a compile)
                ratio = "(start-up differed between the two runs: rerun)"
            print(f"{case:<16} {name:<13} {old:>12,.0f} {new:>12,.0f}  {ratio}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
