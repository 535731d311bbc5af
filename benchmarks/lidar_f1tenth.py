"""tinyrace's lidar against F1TENTH's own scan (f1tenth_gym's ``ScanSimulator2D``), side by
side on F1TENTH's example map: errors against an exact traversal of the map's pixels, and
time per scan.

F1TENTH's code is not copied here: its ``laser_models.py`` and ``examples/example_map``
(.yaml, .png: 1600 x 1600 px at 0.0625 m/px) are read from a fetched copy of the
f1tenth/f1tenth_gym repository (a git directory, ``--f1tenth``) into a temporary folder
and run from there (numba compiles it, as in f1tenth_gym). Its scan is set up as
f1tenth_gym's car does: 1080 beams over 4.7 rad, 30 m, no noise.

Poses: 200 on F1TENTH's example raceline (``example_waypoints.csv``), each moved up to
0.3 m across it and turned up to 0.3 rad, seeded. The reference is
``tests/lidar_reference.py``'s Amanatides-Woo traversal of the occupied pixels at the
beams' nominal angles (pose heading - fov / 2 + i fov / 1079), from the same point. The
map is anti-aliased: its YAML says occupied above occupied_thresh 0.45 (grey < 140.25,
tinyrace's rule), F1TENTH's scan takes grey <= 128; F1TENTH's error is given against the
traversal of either set of pixels.

Time: each scan of each simulator at each pose, ROUNDS alternating rounds, the fastest
round per simulator kept; the ratio is F1TENTH's time over tinyrace's (numba path), and the
numpy path's is given too. Run from the repository root:

    python benchmarks/lidar_f1tenth.py [--f1tenth /work/.mirror/f1tenth+f1tenth_gym/repo]
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

import tinyrace  # noqa: E402, F401  (registers the env ids)
from lidar_reference import scan as reference_scan  # noqa: E402
from tinyrace.sensors.lidar import LidarSensor  # noqa: E402

BEAMS, FOV, MAX_RANGE = 1080, 4.7, 30.0  # f1tenth_gym's car: beams, [rad], [m]
POSES, ROUNDS = 200, 5
FILES = {
    "gym/f110_gym/envs/laser_models.py": "laser_models.py",
    "examples/example_map.yaml": "example_map.yaml",
    "examples/example_map.png": "example_map.png",
    "examples/example_waypoints.csv": "example_waypoints.csv",
}


def extract(repo: Path, folder: Path) -> None:
    """F1TENTH's files from the git directory ``repo`` (its HEAD) into ``folder``."""
    for path, name in FILES.items():
        data = subprocess.run(
            ["git", "--git-dir", str(repo), "show", f"HEAD:{path}"], check=True, capture_output=True
        ).stdout
        (folder / name).write_bytes(data)


def poses(folder: Path, count: int, seed: int) -> np.ndarray:
    """(count, 3) [m, m, rad] near F1TENTH's example raceline."""
    rows = np.loadtxt(folder / "example_waypoints.csv", delimiter=";", comments="#")
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(rows), count, replace=False)
    x, y, psi = rows[pick, 1], rows[pick, 2], rows[pick, 3]
    heading = psi + math.pi / 2  # F1TENTH's psi: 0 along +y
    across = rng.uniform(-0.3, 0.3, count)
    x, y = x - across * np.sin(heading), y + across * np.cos(heading)
    return np.column_stack((x, y, heading + rng.uniform(-0.3, 0.3, count)))


def tinyrace_lidar(folder: Path, spawn: np.ndarray, kernel: str) -> LidarSensor:
    sensor = {"id": "lidar", "type": "lidar", "beams": BEAMS, "fov": math.degrees(FOV),
              "max_range": MAX_RANGE}  # fmt: skip
    config = {
        "track": {"type": "ros_map", "file": "example_map.yaml", "spawn": spawn.tolist()},
        "car": {"model": "kinematic_throttle", "wheelbase": 0.33, "track_width": 0.3},
        "sensors": [sensor],
    }
    (folder / "env.yaml").write_text(yaml.safe_dump(config))
    env = gym.make("tinyrace/TinyRace-v0", config=str(folder / "env.yaml"))
    env.reset(seed=0)
    own: LidarSensor = env.unwrapped.sensors[0]
    lidar = LidarSensor(own.config, MAX_RANGE, own.cell, (), kernel, exact_only=True)
    lidar.reset(env.unwrapped.layout)
    return lidar


def errors(ranges: np.ndarray, reference: np.ndarray) -> str:
    error = np.abs(ranges - reference)
    return (
        f"median {np.median(error) * 1000:.4f} mm, p99 {np.percentile(error, 99) * 1000:.4f} mm, "
        f"max {error.max() * 1000:.4f} mm"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--f1tenth", type=Path,
                        default=Path("/work/.mirror/f1tenth+f1tenth_gym/repo"))  # fmt: skip
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        extract(args.f1tenth, folder)
        spec = importlib.util.spec_from_file_location("laser_models", folder / "laser_models.py")
        assert spec is not None and spec.loader is not None
        laser = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(laser)
        f1tenth = laser.ScanSimulator2D(BEAMS, FOV, max_range=MAX_RANGE)
        f1tenth.set_map(str(folder / "example_map.yaml"), ".png")
        at = poses(folder, POSES, seed=0)
        lidars = {k: tinyrace_lidar(folder, at[0], k) for k in ("numba", "numpy")}
        lidar = lidars["numba"]
        occupied = lidar.exact
        assert occupied is not None
        info = yaml.safe_load((folder / "example_map.yaml").read_text())
        resolution, origin = float(info["resolution"]), tuple(info["origin"])
        grey = np.asarray(__import__("cv2").imread(str(folder / "example_map.png"), 0))
        yaml_rule = (255 - grey.astype(np.float64)) / 255 > info["occupied_thresh"]
        f1tenth_rule = grey <= 128

        ours, theirs, exact, exact_theirs = [], [], [], []
        best = {"tinyrace numba": math.inf, "tinyrace numpy": math.inf, "f1tenth": math.inf}
        for round_ in range(ROUNDS):
            spent = dict.fromkeys(best, 0.0)
            for x, y, heading in at:
                start = time.perf_counter()
                scan = f1tenth.scan(np.array([x, y, heading]), None)
                middle = time.perf_counter()
                ranges = lidar.scan((x, y), heading, False)
                end = time.perf_counter()
                spent["f1tenth"] += middle - start
                spent["tinyrace numba"] += end - middle
                if round_ < 2:  # the numpy path is slow: two rounds
                    start = time.perf_counter()
                    twin = lidars["numpy"].scan((x, y), heading, False)
                    spent["tinyrace numpy"] += time.perf_counter() - start
                    assert np.array_equal(twin, ranges), "the numpy path differs"
                if round_ == 0:
                    angles = heading + lidar.angles
                    ours.append(ranges)
                    theirs.append(scan)
                    exact.append(reference_scan(yaml_rule, resolution, origin, (x, y), angles,
                                                MAX_RANGE))  # fmt: skip
                    exact_theirs.append(reference_scan(f1tenth_rule, resolution, origin, (x, y),
                                                       angles, MAX_RANGE))  # fmt: skip
            for key, value in spent.items():
                if value > 0:
                    best[key] = min(best[key], value)
        ours_all, theirs_all = np.concatenate(ours), np.concatenate(theirs)
        exact_all, exact_theirs_all = np.concatenate(exact), np.concatenate(exact_theirs)
        print(f"F1TENTH's example map: {grey.shape[1]} x {grey.shape[0]} px at {resolution} m/px;"
              f" {POSES} poses x {BEAMS} beams over {FOV} rad, {MAX_RANGE} m")  # fmt: skip
        print(
            f"occupied pixels: {yaml_rule.sum()} by the YAML's occupied_thresh, "
            f"{f1tenth_rule.sum()} by F1TENTH's grey <= 128"
        )
        print("errors against the exact traversal of the YAML's occupied pixels:")
        print(f"  tinyrace: {errors(ours_all, exact_all)}")
        print(f"  F1TENTH:  {errors(theirs_all, exact_all)}")
        print("F1TENTH's error against the traversal of its own (grey <= 128) pixels:")
        print(f"  F1TENTH:  {errors(theirs_all, exact_theirs_all)}")
        per_scan = {key: value / POSES * 1e6 for key, value in best.items()}
        print("time per scan (fastest of the rounds, us):")
        for key, value in per_scan.items():
            print(f"  {key}: {value:,.0f}")
        ratio = per_scan["f1tenth"] / per_scan["tinyrace numba"]
        print(f"F1TENTH's scan takes {ratio:.2f}x tinyrace's compiled scan")


if __name__ == "__main__":
    main()
