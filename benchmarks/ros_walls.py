"""Steps/s on ROS maps of two git refs side by side: ``python benchmarks/ros_walls.py OLD NEW``.

The walls of a ROS map (the occupied pixels as rectangles, issue 38) and the contacts
judged on each step's overlap cost the step something; this measures how much, on the
shipped ``f1tenth_loop`` (the kinematic car) and on f1tenth_gym's example map
(``tests/data/f1tenth_example``, the f1tenth single-track car), each driven by seeded
random actions (they run into the walls about every other step). Each ref is checked out
into a temporary git worktree; rounds alternate OLD, NEW, OLD, NEW in fresh subprocesses,
each timing the thread's CPU time (less hit by other jobs on a shared machine than the
wall clock). The example's raceline is copied without its closing row (a ref from before
issue 38 refuses it). Prints the median steps/s per ref and case, and NEW/OLD.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from compare import print_table, side_by_side

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "tests" / "data" / "f1tenth_example"

ROUND = r"""
import json, sys, time
import gymnasium as gym
import tinyrace
steps, kwargs = int(sys.argv[1]), json.loads(sys.argv[2])
env = gym.make("tinyrace/TinyRace-v0", **kwargs)
env.action_space.seed(0)
actions = [env.action_space.sample() for _ in range(1024)]
env.reset(seed=0)
def run(n):
    for i in range(n):
        _, _, terminated, truncated, _ = env.step(actions[i % len(actions)])
        if terminated or truncated:
            env.reset()
run(200)
start = time.thread_time()
run(steps)
print(json.dumps(steps / (time.thread_time() - start)))
"""


def cases(folder: Path) -> dict[str, dict[str, object]]:
    """The envs' keywords; f1tenth_gym's example copied into ``folder`` as both refs read it."""
    for name in ("example_map.png", "example_map.yaml"):
        shutil.copy(EXAMPLE / name, folder / name)
    track = (EXAMPLE / "track.yaml").read_text()  # a wall stops the car, the episode goes on
    (folder / "track.yaml").write_text(track.replace("ends_episode: true", "ends_episode: false"))
    rows = (EXAMPLE / "example_waypoints.csv").read_text().splitlines()
    (folder / "example_waypoints.csv").write_text("\n".join(rows[:-1]) + "\n")
    return {
        "f1tenth_loop": {"environment": "f1tenth_loop", "sim": {"step_limit": 10**9}},
        "f1tenth_example": {
            "config": str(folder / "track.yaml"),
            "sim": {"step_limit": 10**9},
        },
    }


def one_round(tree: Path, kwargs: dict[str, object], steps: int) -> float:
    done = subprocess.run(
        [sys.executable, "-c", ROUND, str(steps), json.dumps(kwargs)],
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
    parser.add_argument("--rounds", type=int, default=7, help="rounds per ref and case")
    parser.add_argument("--steps", type=int, default=3000, help="timed steps per round")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="tinyrace-ros-walls-") as tmp:
        envs = cases(Path(tmp))
        rates = side_by_side(
            args.old,
            args.new,
            Path(tmp),
            list(envs),
            args.rounds,
            lambda tree, case: one_round(tree, envs[case], args.steps),
        )
    print_table(args.old, args.new, list(envs), rates, f"median CPU steps/s of {args.rounds}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
