"""What each sensor type adds to a step, measured in one run beside bird's-eye cameras.

An env drives with seeded random actions; after every step, each sensor (and each
bird's-eye camera) observes the same snapshot and its ``observe`` (``render``) is timed
on its own, so that every figure of a track kind shares the same steps and the same
machine conditions; the order rotates each step. On a shared machine other processes
pre-empt this one at random, so each probe is timed REPEATS times per step and the fastest
kept; a figure is the median over the steps of those, in µs (the mean is kept too).

Also timed: a reference lidar in the style of F1TENTH's gym (its ``ScanSimulator2D``:
a Euclidean distance transform of the occupied cells, then per beam a loop that steps
by the distance to the nearest obstacle until it is below a small epsilon or past the
range). F1TENTH's gym is not on PyPI and its loop is compiled with numba there; here it is
reimplemented in plain Python, on the same map and beams as tinyrace's lidar (whose padded
border makes the map's edge block, for both). The reference steps by the distance between
cell centres, so its tip ends up to about 1.2 cells inside the blocking cell it stops in (and
may step over an object a cell thick); tinyrace's lidar reports where the beam enters that
cell, within about half a cell. Hence the agreement is given within one and within two cells.

The lidar is timed on both of its paths in the same run: ``lidar_1080`` is the env's own
(the compiled numba kernel when numba imports, what a plain install gives;
else numpy) and ``lidar_1080_numpy`` a second lidar of the same config forced onto the numpy
path, on the same snapshots; every step also checks that both give the same ranges, bit for
bit. numba compiles on the env's first observation (in ``reset``), before any timing;
``measure_compile`` times that first scan in fresh processes, with an empty and then a
filled numba cache. The cone detector likewise: ``cones`` is the env's own (compiled when
numba imports), ``cones_numpy`` the same detector on the numpy path, checked identical every
step, and ``cones_noisy`` the env's path with position noise, misses and false positives.

Cases: the procedural track, formula_student (a picture track with cones) and the shipped
metric tracks (circuit, autocross with its cone map, f1tenth_loop), each with bird's-eye
windows about as large as its own camera's.

Every probe runs on one core (``run.py`` sets cv2's threads to 1 unless ``--cv2-threads``
says otherwise): with cv2's default pool a camera's warp is split over the cores, which on a
2-core VM takes a 96x96 camera about 25% less wall time when the other core is idle.

Budgets (issue 14): state, lookahead and cones add at most 20 µs each; a 1080-beam lidar
(the path a plain install gives) costs no more than a 96x96 bird's-eye camera; a 120x160
perspective camera no more than 1.5x a 120x160 bird's-eye camera.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.util
import math
import os
import subprocess
import sys
import tempfile
import time
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
from tinyrace.examples import TRACKS_DIR
from tinyrace.sensors.cones import ConesSensor
from tinyrace.sensors.lidar import LidarSensor, directions
from tinyrace.world.snapshot import Snapshot

SEED = 0
REPEATS = 3  # timings per probe and step; the fastest is kept
STATE_BUDGET = 20.0  # [µs per step] state, lookahead and cones each
LIDAR_PER_CAMERA = 1.0  # 1080-beam lidar / 96x96 bird's-eye camera
PERSPECTIVE_PER_CAMERA = 1.5  # 120x160 perspective / 120x160 bird's-eye camera

SENSORS = [
    {"id": "state", "type": "state"},
    {"id": "lookahead", "type": "lookahead", "points": 10},
    {"id": "lidar_1080", "type": "lidar", "beams": 1080},
    {"id": "perspective_120x160", "type": "perspective_camera", "resolution": [120, 160]},
]
CASES: dict[str, dict[str, Any]] = {
    "procedural": {
        "config": {
            "cameras": [
                {"id": "birdseye_96x96", "resolution": [96, 96], "roi": [40, 40]},
                {"id": "birdseye_120x160", "resolution": [120, 160], "roi": [40, 53.3]},
            ],
            "sensors": SENSORS,
        },
    },
    "formula_student": {
        "environment": str(TRACKS_DIR / "formula_student"),
        "config": {
            "cameras": [
                {"id": "birdseye_96x96", "resolution": [96, 96], "roi": [360, 360]},
                {"id": "birdseye_120x160", "resolution": [120, 160], "roi": [360, 480]},
            ],
            "sensors": [*SENSORS, {"id": "cones", "type": "cones"}],
        },
    },
}
# the shipped metric tracks: bird's-eye windows about as long as their own camera's [m]
METRIC_WINDOWS = {"circuit": 30.0, "autocross": 12.0, "f1tenth_loop": 3.0}
CONE_TRACKS = ("autocross",)  # metric tracks that list cones


def metric_case(name: str, ahead: float) -> dict[str, Any]:
    """The case of a shipped metric track: bird's-eye windows ``ahead`` [m] long."""
    cameras = [
        {"id": "birdseye_96x96", "resolution": [96, 96], "roi": [ahead, ahead]},
        {"id": "birdseye_120x160", "resolution": [120, 160], "roi": [ahead, ahead * 4 / 3]},
    ]
    cones = [{"id": "cones", "type": "cones"}] if name in CONE_TRACKS else []
    return {"environment": name, "config": {"cameras": cameras, "sensors": [*SENSORS, *cones]}}


CASES.update({name: metric_case(name, ahead) for name, ahead in METRIC_WINDOWS.items()})


def f1tenth_distance(field) -> np.ndarray:
    """F1TENTH's map preparation: the Euclidean distance transform [cells] of the occupied
    cells (here the lidar's own blocking cells), once per map."""
    free = np.where(field.blocking() > 0, 0, 255).astype(np.uint8)  # the edge blocks too
    return cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)


def f1tenth_scan(field, distance, origin, beams: np.ndarray, max_range: float, eps: float = 1e-4):
    """Ranges [track units] by F1TENTH's method, one Python loop per beam: march by the
    distance to the nearest occupied cell until it is below ``eps`` cells (the tip is in an
    occupied cell) or the range is passed; on the same cells, so within about a cell of
    tinyrace's ranges."""
    height, width = distance.shape
    ox, oy = field.to_cells @ (origin[0], origin[1], 1.0)
    linear = field.to_cells[:, :2] / field.cells_per_unit
    limit = max_range * field.cells_per_unit
    ranges = np.empty(len(beams), np.float32)
    for i, (dx, dy) in enumerate(beams @ linear.T):
        t = 0.0
        while t < limit:
            col, row = round(ox + t * dx), round(oy + t * dy)
            if not (0 <= row < height and 0 <= col < width):
                break
            d = float(distance[row, col])
            if d < eps:
                break
            t += d
        ranges[i] = min(t, limit) / field.cells_per_unit
    return ranges


def _probes(raw, extra: list, snapshot: Snapshot, rng: np.random.Generator) -> list:
    """(id, call) of every sensor's observe (the bird's-eye cameras are sensors too), and of
    the ``extra`` (id, sensor) pairs."""
    track = raw.layout
    sensors = [(s.id, s) for s in raw.sensors] + extra
    return [(i, functools.partial(s.observe, snapshot, track, rng)) for i, s in sensors]


def numpy_twin(lidar: LidarSensor) -> LidarSensor:
    """A lidar like ``lidar`` on the numpy path."""
    return LidarSensor(lidar.config, lidar.max_range, lidar.cell, lidar.cone_colors, "numpy")


def cone_twins(cones: ConesSensor | None) -> list[tuple[str, ConesSensor]]:
    """(id, sensor) of a cone detector like ``cones`` on the numpy path (when ``cones`` is
    on the compiled one), and of one on ``cones``' path with noise, misses and false
    positives."""
    if cones is None:
        return []
    noise = {"position_std": cones.max_range / 300, "miss_probability": 0.1, "false_positives": 1}
    noisy = dataclasses.replace(cones.config, id="cones_noisy", **noise)
    twins = [("cones_noisy", ConesSensor(noisy, cones.max_range, cones.kernel))]
    if cones.kernel != "numpy":
        twins.append(("cones_numpy", ConesSensor(cones.config, cones.max_range, "numpy")))
    return twins


def _fastest(call) -> float:
    """[s] the fastest of REPEATS calls."""
    best = math.inf
    for _ in range(REPEATS):
        began = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - began)
    return best


def measure_case(name: str, steps: int, reference_steps: int) -> dict[str, Any]:
    """Mean µs per step of each sensor and camera of ``CASES[name]`` over ``steps`` steps."""
    case = CASES[name]
    kwargs = {"environment": case["environment"]} if "environment" in case else {}
    env = gym.make("tinyrace/TinyRace-v0", **kwargs, **case["config"])
    raw = env.unwrapped
    env.action_space.seed(SEED)
    rng = np.random.default_rng(SEED)
    env.reset(seed=SEED)
    samples: dict[str, list[float]] = {}
    lidar = next(s for s in raw.sensors if isinstance(s, LidarSensor))
    twin = numpy_twin(lidar)
    twin.reset(raw.layout)
    extra = [(f"{lidar.id}_numpy", twin)] if lidar.kernel != "numpy" else []
    cones = next((s for s in raw.sensors if isinstance(s, ConesSensor)), None)
    cone_extra = dict(cone_twins(cones))
    for cone_twin in cone_extra.values():
        cone_twin.reset(raw.layout)
    extra += list(cone_extra.items())
    cone_steps = 0  # steps whose cones both paths detect alike
    reference_seconds, differences, identical = 0.0, [], 0
    for step in range(steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
            for sensor in (twin, *cone_extra.values()):
                sensor.reset(raw.layout)
        snapshot = raw.snapshot()
        ranges, numpy_ranges = (s.observe(snapshot, raw.layout, rng) for s in (lidar, twin))
        identical += ranges.tobytes() == numpy_ranges.tobytes()
        if cones is not None and "cones_numpy" in cone_extra:
            pair = (cones, cone_extra["cones_numpy"])
            seen = [
                {
                    k: np.asarray(v).tobytes()
                    for k, v in c.observe(snapshot, raw.layout, rng).items()
                }
                for c in pair
            ]
            cone_steps += seen[0] == seen[1]
        probes = _probes(raw, extra, snapshot, rng)
        shift = step % len(probes)
        for probe_id, probe in probes[shift:] + probes[:shift]:
            samples.setdefault(probe_id, []).append(_fastest(probe))
        if step < reference_steps:
            origin = lidar.origin(snapshot, raw.layout)
            beams = directions(lidar.angles, snapshot.car.pose[2], raw.layout.y_down)
            field = lidar.field if lidar.field is not None else lidar.exact  # a ROS map's
            distance = f1tenth_distance(field)  # once per map in F1TENTH: not timed
            began = time.perf_counter()
            ranges = f1tenth_scan(field, distance, origin, beams, lidar.max_range)
            reference_seconds += time.perf_counter() - began
            ours = lidar.observe(snapshot, raw.layout, rng)
            differences.append(np.abs(ranges - ours))
    env.close()
    micros = {k: 1e6 * float(np.median(v)) for k, v in samples.items()}
    means = {k: 1e6 * float(np.mean(v)) for k, v in samples.items()}
    micros["f1tenth_reference_lidar_1080"] = 1e6 * reference_seconds / max(reference_steps, 1)
    field = lidar.field if lidar.field is not None else lidar.exact
    assert field is not None  # the lidar has observed a track
    cell = 1.0 / field.cells_per_unit
    return {
        "steps": steps,
        "lidar_kernel": lidar.kernel,
        "lidar_steps_identical_to_numpy": identical,
        "cones_kernel": cones.kernel if cones is not None else None,
        "cones_steps_identical_to_numpy": cone_steps,
        "us_per_step": micros,
        "us_per_step_mean": means,
        "lidar_cell": cell,
        # beams that clip the corner of a cell may hit it in one method and not the other
        "lidar_beams_within_a_cell_of_reference": float(
            np.mean(np.concatenate(differences) <= cell)
        ),
        "lidar_beams_within_two_cells_of_reference": float(
            np.mean(np.concatenate(differences) <= 2 * cell)
        ),
    }


COMPILE_PROBE = """
import time
began = time.perf_counter()
import numpy as np
from tinyrace.sensors.kernels import raycast as raycast_numba
from tinyrace.sensors.lidar import beam_angles
from tinyrace.sensors.machinery.raycast import beam_fan, distance_field, fan_angle
imported = time.perf_counter() - began
blocking = np.random.default_rng(0).random((400, 400)) < 0.01
field = distance_field(blocking, np.eye(2, 3), reach=200.0, near=False)
angles = beam_angles(1080, 2 * np.pi)
fan = beam_fan(field, angles, 200.0, tables=False)
first, reverse = fan_angle(field, angles, 0.3, False)
seconds = []
for _ in range(2):
    began = time.perf_counter()
    raycast_numba.cast(field, fan, (200.2, 199.7), first, reverse)
    seconds.append(time.perf_counter() - began)
print(imported, *seconds)
"""


def measure_compile() -> dict[str, float]:
    """[s] importing numba and the kernel, and the first and second scan of a 1080-beam
    lidar (whose field reaches past the tables, so that every compiled function is needed),
    each in a fresh process: with an empty numba cache (the first scan compiles) and then
    with the cache it filled (the first scan loads the machine code). Empty without numba."""
    result: dict[str, float] = {}
    if importlib.util.find_spec("numba") is None:
        return result
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for label in ("cold_cache", "warm_cache"):
            out = subprocess.run(
                [sys.executable, "-c", COMPILE_PROBE], env=env, check=True,
                capture_output=True, text=True,
            ).stdout  # fmt: skip
            imported, first, second = map(float, out.split())
            result.update({f"{label}_import_s": imported, f"{label}_first_scan_s": first,
                           f"{label}_second_scan_s": second})  # fmt: skip
    return result


def print_compile(result: dict[str, float]) -> None:
    """The compile times of ``measure_compile``."""
    if not result:
        print("\nLidar kernel: numba did not import (pip install numba)")
        return
    print("\nLidar kernel (numba) start-up, fresh processes [s]:")
    for label in ("cold_cache", "warm_cache"):
        first, imported = result[f"{label}_first_scan_s"], result[f"{label}_import_s"]
        second = result[f"{label}_second_scan_s"]
        print(f"  {label}: import {imported:.3f}, first scan {first:.3f}, second {second:.6f}")


def measure_sensors(steps: int = 2000, reference_steps: int = 20) -> dict[str, Any]:
    """Every case, and the budget checks."""
    results = {name: measure_case(name, steps, reference_steps) for name in CASES}
    for result in results.values():
        us = result["us_per_step"]
        kernel = result["lidar_kernel"]
        result["checks"] = {
            **{
                f"{k} <= {STATE_BUDGET:g} us": us[k] <= STATE_BUDGET
                for k in ("state", "lookahead", "cones")
                if k in us
            },
            f"lidar_1080 ({kernel}) <= birdseye_96x96": us["lidar_1080"]
            <= LIDAR_PER_CAMERA * us["birdseye_96x96"],
            "lidar_1080 identical to numpy every step": result["lidar_steps_identical_to_numpy"]
            == result["steps"],
            "perspective_120x160 <= 1.5 x birdseye_120x160": us["perspective_120x160"]
            <= PERSPECTIVE_PER_CAMERA * us["birdseye_120x160"],
        }
        if result["cones_kernel"] not in (None, "numpy"):
            result["checks"]["cones identical to numpy every step"] = (
                result["cones_steps_identical_to_numpy"] == result["steps"]
            )
    return results


def print_sensors(results: dict[str, Any]) -> None:
    """The per-sensor table and the budget checks."""
    for name, result in results.items():
        if "error" in result:
            print(f"\nSensors on {name}: {result['error']}")
            continue
        print(f"\nSensors on {name} (median us per step over {result['steps']} steps)")
        us = result["us_per_step"]
        for key, value in sorted(result["us_per_step"].items(), key=lambda kv: kv[1]):
            print(f"  {key:32s} {value:10.1f}")
        camera = us["birdseye_96x96"]
        lidars = [k for k in us if k.startswith("lidar_1080") or k.startswith("f1tenth")]
        ratios = ", ".join(f"{k} {us[k] / camera:.2f}x" for k in lidars)
        print(f"  per birdseye_96x96 ({result['lidar_kernel']} path first): {ratios}")
        agree, cell = result["lidar_beams_within_a_cell_of_reference"], result["lidar_cell"]
        two = result["lidar_beams_within_two_cells_of_reference"]
        print(
            f"  lidar vs reference: {100 * agree:.1f} % of beams within a cell ({cell:.3g}),"
            f" {100 * two:.1f} % within two"
        )
        for check, passed in result["checks"].items():
            print(f"  {'PASS' if passed else 'FAIL'}  {check}")


if __name__ == "__main__":
    cv2.setNumThreads(1)  # cost per core, as benchmarks/run.py measures (--cv2-threads)
    print_sensors(measure_sensors())
    print_compile(measure_compile())
