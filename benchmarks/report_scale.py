"""``tinyrace report`` on a run of many episodes: wall time and peak memory of two git refs
side by side, on the same run folder.

A real run of the shipped ``carracing`` experiment (2 episodes, no video) is made once with
the checkout's tinyrace, then its rows are repeated to ``--episodes`` rows (each its own
episode number, every trace the same file, the first track), as a run of that many episodes
would write them. Each ref's ``tinyrace report`` rebuilds it in its own process (a ``git
worktree`` of the ref on ``PYTHONPATH``); rounds alternate between the refs.

    python benchmarks/report_scale.py OLD NEW --episodes 5000 --rounds 2
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("refs", nargs=2, help="two git refs, e.g. 5b29eaf HEAD")
    parser.add_argument("--episodes", type=int, default=5000)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="report-scale-") as scratch:
        work = Path(scratch)
        run = many_episodes(base_run(work), work / "many", args.episodes)
        trees = [worktree(ref, work / f"tree{i}") for i, ref in enumerate(args.refs)]
        try:
            times: dict[str, list[tuple[float, float]]] = {ref: [] for ref in args.refs}
            for _ in range(args.rounds):
                for ref, tree in zip(args.refs, trees, strict=True):
                    folder = work / f"round-{ref}"
                    shutil.rmtree(folder, ignore_errors=True)
                    shutil.copytree(run, folder)
                    times[ref].append(timed_report(tree, folder))
        finally:
            for tree in trees:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                               check=False, capture_output=True)  # fmt: skip
    print(f"tinyrace report, {args.episodes:,} episodes (median of {args.rounds} rounds):")
    for ref, rounds in times.items():
        wall = sorted(t for t, _ in rounds)[len(rounds) // 2]
        peak = max(m for _, m in rounds)
        print(f"  {ref:>12}: {wall:8.1f} s, peak RSS {peak:6.0f} MB")


def base_run(work: Path) -> Path:
    """A two-episode run of the shipped carracing experiment, by this checkout's tinyrace."""
    out = work / "base"
    command = [sys.executable, "-m", "tinyrace", "run", "carracing", "--episodes", "2",
               "--no-video", "--quiet", "-o", str(out)]  # fmt: skip
    subprocess.run(command, check=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    (run,) = out.iterdir()
    return run


def many_episodes(run: Path, target: Path, count: int) -> Path:
    """``run``'s folder with its first episode's row repeated as episodes 0..count-1."""
    shutil.copytree(run, target)
    with (run / "episodes.csv").open(newline="") as file:
        rows = list(csv.DictReader(file))
    first = rows[0]
    with (target / "episodes.csv").open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(first))
        writer.writeheader()
        for episode in range(count):
            writer.writerow({**first, "episode": episode, "seed": episode})
    header = json.loads((run / "results.json").read_text())
    header["episodes_planned"] = count
    (target / "results.json").write_text(json.dumps(header))
    return target


def worktree(ref: str, path: Path) -> Path:
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(path), ref],
                   check=True, capture_output=True)  # fmt: skip
    return path


# run in a process of its own, whose only child is the report: its children's peak RSS
MEASURE = """
import resource, subprocess, sys, time
start = time.perf_counter()
subprocess.run([sys.executable, "-m", "tinyrace", "report", sys.argv[1]], check=True,
               capture_output=True)
print(time.perf_counter() - start, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
"""


def timed_report(tree: Path, folder: Path) -> tuple[float, float]:
    """[s] wall time and [MB] peak RSS of ``tinyrace report`` of ``tree`` on ``folder``."""
    env = {**os.environ, "PYTHONPATH": str(tree), "MPLBACKEND": "Agg"}
    command = [sys.executable, "-c", MEASURE, str(folder)]  # from the tree: sys.path[0]
    done = subprocess.run(command, check=True, env=env, cwd=tree, capture_output=True, text=True)
    wall, peak = done.stdout.split()
    return float(wall), int(peak) / 1024  # [KiB] -> [MB]


if __name__ == "__main__":
    main()
