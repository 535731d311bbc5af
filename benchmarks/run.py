"""Speed and memory of tinyrace beside Gymnasium's CarRacing-v3 and EnvPool, in one run.

Usage::

    python benchmarks/run.py                   # a few seconds per case (about 2 minutes)
    python benchmarks/run.py --quick           # smoke run (under a minute)
    python benchmarks/run.py --out FILE.json   # default: benchmarks/results/latest.json
    python benchmarks/run.py --sensors         # only the per-sensor costs (sensors.json)
    python benchmarks/run.py --scaling         # only the 1..32 envs in one process table

Every case steps one env with seeded random actions (drawn up front, so drawing
them is not timed) and takes the observation of every step; an env whose
episode ends is reset inside the timed loop, as a training loop would (steps/s
are also given without that reset time). Each timing follows a warm-up, and
cases that are compared are timed in interleaved rounds so that they share the
machine's conditions. Measured:

- steps/s of ``tinyrace/CarRacing-v0`` (``gym.make``, wrappers included), of
  Gymnasium's ``CarRacing-v3`` and of EnvPool's ``CarRacing-v3`` (1 env, 1 thread;
  "not installed" when envpool cannot be imported);
- reset time of tinyrace and CarRacing-v3: mean over seeded resets [ms];
- steps/s on the image tracks under ``example_tracks/`` with one 120x160 camera
  and with three, and on a generated 6000x3000 track beside a 1000x1000 one;
  a case that cannot run is reported as ``unavailable: <error>``;
- peak RSS of one env of each kind, each in a fresh process, after creating it,
  a reset and 200 steps; beside a process that only imports gymnasium, numpy,
  cv2 and pymunk;
- env-steps/s of 1, 2, 4, 8, 16 and 32 envs stepped in this one process by the vector
  entry point (``make_batch(workers=0)``: the cars' tyre forces as one numpy computation),
  and of ``SyncVectorEnv`` with 8, against one env's, in wall and in CPU time;
- tinycarlo 1.1's steps/s on the example tracks, each with one 120x160 camera, run by
  ``tinycarlo_steps.py`` in an interpreter that imports tinycarlo ($TINYCARLO_PYTHON,
  /tmp/tc/bin/python or this one; "not installed" otherwise), beside tinyrace's; its
  episodes end when the car leaves the image, as tinyrace's do (tinycarlo's own loop,
  whose car drives on over black ground, is given too). tinycarlo's own examples (the folders
  under ``example_tracks/`` of its repository at 1.1, github.com/danielriege/tinycarlo; its
  wheel and sdist ship none) are timed the same way when ``--tinycarlo-examples DIR`` (or
  $TINYCARLO_EXAMPLES) names that folder; their images are 2.5-5x larger than tinyrace's, and
  tinycarlo warps the whole image every step;
- ``SyncVectorEnv`` and ``AsyncVectorEnv`` (2 envs, 2 workers) env-steps/s of
  ``tinyrace/CarRacing-v0`` against one env's steps/s, and tinyrace's
  ``BatchVectorEnv`` (8 envs in 2 workers, one message per worker and step);
- beside them, the ceiling: ``AsyncVectorEnv`` (2 workers) of a stand-in env that only
  busy-waits, against one such stand-in, for three step times from this run: tinyrace's,
  the longest one that meets the 30x-CarRacing-v3 target, and CarRacing-v3's.

Drawing runs on one core: cv2's thread pool would otherwise split a camera's warp over the
machine's cores (on this 2-core VM a 96x96 camera then takes about 25% less wall time when
the second core is idle, for twice the CPU time), while CarRacing-v3, EnvPool (1 thread) and
the compiled kernels use one. ``--cv2-threads N`` sets cv2's threads of this process and of
the processes it starts (``OPENCV_FOR_THREADS_NUM``); the default 1 measures cost per core.

It prints the targets with PASS/FAIL, then the figures behind them, and writes
every figure as JSON. Memory is in MB of 10^6 bytes. ``profile_step.py`` shows
where a step's time goes; ``floor_step.py``, what a step would cost without tinyrace's
layers (the same observations and rewards from pymunk, cv2 and the compiled kernels alone).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import traceback
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
import yaml
from tinyrace.examples import TRACKS_DIR

from report import (
    BIG,
    EXAMPLE_TRACKS,
    SMALL,
    TARGETS,
    print_table,
    rate_of,
    ratio_row,
    report,
    verdict,
    why_missing,
)
from sensors import measure_compile, measure_sensors, print_compile, print_sensors
from standin import StandIn
from stepping import SEED, Stepper, interleave, quiet_gym_warnings, time_resets, unavailable

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_OUT = ROOT / "benchmarks" / "results" / "latest.json"
RSS_STEPS = 200
GENERATED_SIZES = {SMALL: (1000, 1000), BIG: (6000, 3000)}  # (width, height) [px]
BATCH_ENVS = 8  # envs of the BatchVectorEnv case, in 2 workers
SCALING_ENVS = (1, 2, 4, 8, 16, 32)  # envs stepped in one process (batched, and SyncVectorEnv)
ENV_WARMUP_STEPS = {False: 2000, True: 200}  # steps of every env before the scaling table
TINYCARLO_SCRIPT = Path(__file__).resolve().parent / "tinycarlo_steps.py"

FRONT = {"id": "front", "resolution": [120, 160], "roi": [360, 480]}
ONE_CAMERA = [FRONT]
THREE_CAMERAS = [
    FRONT,
    {"id": "left", "resolution": [120, 160], "roi": [360, 480], "yaw": -90},
    {"id": "rear", "resolution": [120, 160], "roi": [360, 480], "yaw": 180},
]


@dataclass(frozen=True)
class Budget:
    """How long each case runs."""

    seconds: float  # [s] timed per case, split over the rounds
    rounds: int  # interleaved rounds per comparison
    warmup: float  # [s] stepped before timing
    resets: int  # seeded resets timed per env


FULL = Budget(seconds=4.0, rounds=8, warmup=0.5, resets=20)
QUICK = Budget(seconds=1.0, rounds=2, warmup=0.2, resets=5)


# -- envs -------------------------------------------------------------------------------------
def make_tinyrace(env_id: str = "tinyrace/CarRacing-v0", **kwargs: Any) -> gym.Env:
    import tinyrace  # noqa: F401  (registers the ids)

    return gym.make(env_id, **kwargs)


def make_image_track(folder: str | Path, cameras: list[dict] | None = None) -> gym.Env:
    kwargs: dict[str, Any] = {"environment": str(folder)}
    if cameras is not None:
        kwargs["cameras"] = cameras
    return make_tinyrace("tinyrace/TinyRace-v0", **kwargs)


def make_envpool() -> Any:
    """EnvPool's CarRacing-v3, one env on one thread; raises ImportError when absent."""
    import envpool

    return envpool.make(
        "CarRacing-v3", env_type="gymnasium", num_envs=1, batch_size=1, num_threads=1, seed=SEED
    )


def write_generated_track(folder: Path, width: int, height: int) -> Path:
    """A tinycarlo track folder: an elliptic road loop, its centre line as trajectory, one box.

    Colours (BGR): white road edges, green trajectory, a red obstacle box (reward -1)
    a quarter lap ahead of the spawn. The car spawns on the trajectory, heading along it.
    """
    folder.mkdir(parents=True, exist_ok=True)
    image = np.zeros((height, width, 3), np.uint8)
    margin, half_road, box = 180, 120, 30  # [px]
    cx, cy = width // 2, height // 2
    a, b = cx - margin, cy - margin  # [px] trajectory radii
    for offset in (-half_road, half_road):
        cv2.ellipse(image, (cx, cy), (a + offset, b + offset), 0, 0, 360, (255, 255, 255), 8)
    cv2.ellipse(image, (cx, cy), (a, b), 0, 0, 360, (0, 255, 0), 2)
    cv2.rectangle(image, (cx - box, cy + b - box), (cx + box, cy + b + box), (0, 0, 255), -1)
    cv2.imwrite(str(folder / "track.png"), image)
    config = {
        "sim": {"fps": 30, "render_realtime": False, "step_limit": 1000},
        "reward_design": {
            "color_obstacles": [{"color": [0, 0, 255], "reward": -1}],
            "cross_track_error": {"use_cte": True, "trajectory_color": [0, 255, 0]},
        },
        "car": {"wheelbase": 150, "track_width": 100, "velocity": 400, "max_steering_change": 180},
        "cameras": ONE_CAMERA,
        # the ellipse's rightmost point; heading pi/2 is +y on screen: along the loop
        "tracks": [{"image": "track.png", "spawns": [[cx + a, cy, math.pi / 2]]}],
    }
    (folder / "track.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    return folder


def image_track_cases(generated_dir: Path) -> dict[str, Callable[[], gym.Env]]:
    """Every image-track case by name: example tracks x (1, 3) cameras, and generated tracks."""
    cases: dict[str, Callable[[], gym.Env]] = {}
    for name in EXAMPLE_TRACKS:
        folder = TRACKS_DIR / name
        cases[f"{name}_1cam"] = lambda f=folder: make_image_track(f, ONE_CAMERA)
        cases[f"{name}_3cam"] = lambda f=folder: make_image_track(f, THREE_CAMERAS)
    for name in GENERATED_SIZES:
        cases[name] = lambda f=generated_dir / name: make_image_track(f, ONE_CAMERA)
    return cases


# -- measurements -----------------------------------------------------------------------------
def measure_throughput(budget: Budget) -> dict[str, Any]:
    """steps/s of tinyrace, CarRacing-v3 and EnvPool, interleaved."""
    steppers = {
        "tinyrace": Stepper(make_tinyrace()),
        "carracing_v3": Stepper(gym.make("CarRacing-v3")),
    }
    results: dict[str, Any] = {}
    try:
        steppers["envpool"] = Stepper(make_envpool(), auto_reset=True, add_batch_axis=True)
    except ImportError:
        results["envpool"] = "not installed"
    return {**timed(steppers, budget), **results}


def measure_reset(budget: Budget) -> dict[str, Any]:
    """Mean time of a seeded reset [ms], tinyrace and CarRacing-v3 alternating."""
    envs = {"tinyrace": make_tinyrace(), "carracing_v3": gym.make("CarRacing-v3")}
    try:
        return time_resets(envs, range(1, budget.resets + 1))
    finally:
        for env in envs.values():
            env.close()


def measure_image_tracks(budget: Budget, generated_dir: Path) -> dict[str, Any]:
    """steps/s of each image-track case that runs; the others say why they cannot."""
    cases = image_track_cases(generated_dir)
    results: dict[str, Any] = {}
    steppers: dict[str, Stepper] = {}
    for name, make in cases.items():
        try:
            stepper = Stepper(make())
            stepper.run(0.01)  # fail here rather than in the middle of the timed rounds
            steppers[name] = stepper
        except Exception as error:
            results[name] = unavailable(error)
    results.update(timed(steppers, budget))
    return {name: results[name] for name in cases}


METRIC_TRACKS = ("circuit", "autocross", "f1tenth_loop")  # the shipped tracks in metres


def measure_track_sources(budget: Budget) -> dict[str, Any]:
    """steps/s of each shipped metric track (its own track.yaml: camera, throttle car) beside
    the procedural track's (CarRacing-v0), random actions, in one interleaved run."""
    cases: dict[str, Callable[[], gym.Env]] = {"procedural": make_tinyrace}
    for name in METRIC_TRACKS:
        cases[name] = lambda name=name: make_tinyrace("tinyrace/TinyRace-v0", environment=name)
    return timed({name: Stepper(make()) for name, make in cases.items()}, budget)


def print_track_sources(results: dict[str, Any]) -> None:
    print(f"\n{'track':<14}{'steps/s':>10}{'vs procedural':>16}")
    base = results["procedural"]["steps_per_s"]
    for name, timing in results.items():
        rate = timing["steps_per_s"]
        print(f"{name:<14}{rate:>10,.0f}{rate / base:>15.2f}x")


def measure_vector(budget: Budget) -> dict[str, Any]:
    """Env-steps/s of one env, SyncVectorEnv(2), AsyncVectorEnv(2 workers) and
    BatchVectorEnv(8 envs, 2 workers), interleaved."""
    from tinyrace.vector import BatchVectorEnv  # here: the RSS baseline must not import tinyrace

    makers = [make_tinyrace, make_tinyrace]
    steppers = {"single": Stepper(make_tinyrace())}
    results: dict[str, Any] = {}
    for name, make_vector, batch in (
        ("sync_2", lambda: gym.vector.SyncVectorEnv(makers), 2),
        ("async_2", lambda: gym.vector.AsyncVectorEnv(makers), 2),
        ("batch_2x8", lambda: BatchVectorEnv([make_tinyrace] * BATCH_ENVS, workers=2), BATCH_ENVS),
    ):
        try:
            steppers[name] = Stepper(make_vector(), batch=batch, auto_reset=True)
        except Exception as error:
            results[name] = unavailable(error)
    return {**timed(steppers, budget), **results}


def measure_vector_scaling(budget: Budget) -> dict[str, Any]:
    """Env-steps/s of N envs stepped in this one process, N in SCALING_ENVS, by the vector
    entry point in this process (``make_batch(workers=0)``: batched physics), beside one
    ``gym.make`` env and SyncVectorEnv(8), interleaved. Every env first takes the same
    number of steps, ENV_WARMUP_STEPS: an env's cached car pictures make its first
    thousand steps dearer (CarRacing's view: a cold env renders a car patch every fourth
    step, a warm one every twentieth), and N envs sharing a core would otherwise each be
    N times younger than the one env they are compared with."""
    from tinyrace.vector import make_batch  # here: the RSS baseline must not import tinyrace

    steppers = {"single": Stepper(make_tinyrace())}
    for n in SCALING_ENVS:
        steppers[f"one_process_{n}"] = Stepper(
            make_batch("tinyrace/CarRacing-v0", n, workers=0), batch=n, auto_reset=True
        )
    steppers["sync_8"] = Stepper(
        gym.vector.SyncVectorEnv([make_tinyrace] * 8), batch=8, auto_reset=True
    )
    for stepper in steppers.values():
        stepper.take(ENV_WARMUP_STEPS[budget is QUICK])
    return timed(steppers, budget)


def tinycarlo_python() -> str | None:
    """An interpreter that imports tinycarlo: $TINYCARLO_PYTHON, /tmp/tc's venv, or this one."""
    for candidate in (os.environ.get("TINYCARLO_PYTHON"), "/tmp/tc/bin/python", sys.executable):
        if candidate and Path(candidate).exists():
            probe = [candidate, "-c", "import tinycarlo"]
            if subprocess.run(probe, capture_output=True).returncode == 0:
                return candidate
    return None


def tinycarlo_examples(folder: Path | None) -> dict[str, Path]:
    """tinycarlo's own example track folders under ``folder`` (each holding a track.yaml),
    named ``tinycarlo:<name>``; none when no folder is given."""
    if folder is None:
        return {}
    if not folder.is_dir():
        raise SystemExit(f"--tinycarlo-examples: {folder} is not a folder")
    found = {f"tinycarlo:{t.parent.name}": t.parent for t in sorted(folder.glob("*/track.yaml"))}
    if not found:
        raise SystemExit(f"--tinycarlo-examples: no <name>/track.yaml under {folder}")
    return found


def one_camera_copies(generated_dir: Path, sources: dict[str, Path]) -> dict[str, Path]:
    """The track folders ``sources``, each copied with one 120x160 camera (and a step limit,
    which tinycarlo 1.1 needs), for tinyrace and tinycarlo alike. The originals are only read."""
    folders = {}
    for name, source in sources.items():
        folder = generated_dir / f"one_camera_{name.replace(':', '_')}"
        shutil.copytree(source, folder, dirs_exist_ok=True)
        config = yaml.safe_load((folder / "track.yaml").read_text())
        config.pop("camera", None)
        config["cameras"] = ONE_CAMERA
        config.setdefault("sim", {}).setdefault("step_limit", 1000)
        (folder / "track.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
        folders[name] = folder
    return folders


def measure_tinycarlo(
    budget: Budget, generated_dir: Path, own_examples: Path | None = None
) -> dict[str, Any]:
    """tinycarlo 1.1's steps/s with one 120x160 camera (run in its own interpreter, a
    subprocess) and tinyrace's on the same folders: tinyrace's example tracks, and
    tinycarlo's own examples when ``own_examples`` names their folder."""
    python = tinycarlo_python()
    if python is None:
        return {"error": "not installed (pip install 'tinycarlo==1.1.*', e.g. in a venv /tmp/tc)"}
    sources = {name: TRACKS_DIR / name for name in EXAMPLE_TRACKS}
    folders = one_camera_copies(generated_dir, {**tinycarlo_examples(own_examples), **sources})
    tracks = [f"{name}={folder}" for name, folder in folders.items()]
    seconds = str(max(budget.seconds / 2, 1.0))
    min_steps = "200" if budget is FULL else "20"  # tinycarlo: ~10 steps/s
    command = [python, str(TINYCARLO_SCRIPT), "--seconds", seconds, "--min-steps", min_steps]
    command += tracks
    done = subprocess.run(command, capture_output=True, text=True, timeout=1800)
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines() or [f"exit code {done.returncode}"]
        return {"error": f"unavailable: {lines[-1]}", "interpreter": python}
    results: dict[str, Any] = {"interpreter": python}
    for name, entry in json.loads(done.stdout.strip().splitlines()[-1]).items():
        results[f"tinycarlo_{name}"] = entry
    steppers = {}
    for name, folder in folders.items():
        try:
            steppers[f"tinyrace_{name}"] = Stepper(make_image_track(folder))
        except Exception as error:
            results[f"tinyrace_{name}"] = unavailable(error)
    return {**results, **timed(steppers, budget)}


def measure_vector_ceiling(budget: Budget, throughput: dict[str, Any]) -> dict[str, Any]:
    """One stand-in env and AsyncVectorEnv(2) of them, for step times measured in this run:
    what AsyncVectorEnv makes of a step that long here, whatever the env does in it.

    The step times: tinyrace's, the longest that still meets the ``vs_carracing_v3``
    target (CarRacing-v3's divided by it), and CarRacing-v3's.
    """
    tinyrace = rate_of(throughput.get("tinyrace"), "step_only_per_s")
    v3 = rate_of(throughput.get("carracing_v3"), "step_only_per_s")
    if tinyrace is None or v3 is None:
        return {"error": "unavailable: no step times of tinyrace and CarRacing-v3 in this run"}
    step_seconds = {
        "tinyrace": 1.0 / tinyrace,
        "at_v3_target": 1.0 / (v3 * TARGETS["vs_carracing_v3"]),
        "carracing_v3": 1.0 / v3,
    }
    spaces = make_tinyrace()
    observation_space, action_space = spaces.observation_space, spaces.action_space
    spaces.close()
    steppers: dict[str, Stepper] = {}
    for name, seconds in step_seconds.items():

        def make(seconds: float = seconds) -> StandIn:
            return StandIn(seconds, observation_space, action_space)

        steppers[f"{name}_single"] = Stepper(make())
        steppers[f"{name}_async_2"] = Stepper(
            gym.vector.AsyncVectorEnv([make, make]), batch=2, auto_reset=True
        )
    timings = timed(steppers, budget)
    for name, seconds in step_seconds.items():
        for case in (f"{name}_single", f"{name}_async_2"):
            timings[case]["stand_in_step_seconds"] = seconds
    return timings


def report_informational(results: dict[str, Any]) -> None:
    """Ratios with no target of their own, beside the AsyncVectorEnv target they explain."""
    vector, ceiling = results["vector"], results["vector_ceiling"]
    rows = [
        ratio_row(
            f"BatchVectorEnv(2 workers, {BATCH_ENVS} envs) vs one env",
            vector.get("batch_2x8"),
            vector.get("single"),
            TARGETS["async_ratio"],
        )
    ]
    labels = {
        "tinyrace": "tinyrace's",
        "at_v3_target": f"1/{TARGETS['vs_carracing_v3']:g} of CarRacing-v3's",
        "carracing_v3": "CarRacing-v3's",
    }
    for name, label in labels.items():
        single = ceiling.get(f"{name}_single")
        step = f" ({single['stand_in_step_seconds'] * 1e6:,.0f} us)" if rate_of(single) else ""
        rows.append(
            ratio_row(
                f"AsyncVectorEnv(2) vs one, stand-in step = {label}{step}",
                ceiling.get(f"{name}_async_2"),
                single,
                TARGETS["async_ratio"],
            )
        )
    print_table("Informational", ["measure", "value", "target", "result"], rows)
    report_scaling(results.get("vector_scaling", {}))
    report_tinycarlo(results.get("tinycarlo", {}))


def report_scaling(scaling: dict[str, Any]) -> None:
    """The 1..32 envs table: env-steps/s in one process, wall and CPU time, over one env's."""
    single = scaling.get("single")
    if rate_of(single) is None:
        print(f"\nEnvs in one process: {why_missing(single)}")
        return
    assert isinstance(single, dict)
    rows = [["one env (gym.make)", *_scaling_cells(single, single), "", ""]]
    for n in [*SCALING_ENVS, "sync_8"]:
        entry = scaling.get(f"one_process_{n}" if n != "sync_8" else n)
        label = f"{n} envs, vector entry point" if n != "sync_8" else "8 envs, SyncVectorEnv"
        if rate_of(entry) is None:
            rows.append([label, why_missing(entry), "", "", "", "", ""])
            continue
        assert isinstance(entry, dict)
        ratio = entry["steps_per_s"] / single["steps_per_s"]
        target, result = ("", "")
        if n == 8:
            target = f">= {TARGETS['one_process_8']:g}x"
            result = verdict(ratio >= TARGETS["one_process_8"])
        rows.append([label, *_scaling_cells(entry, single), target, result])
    header = ["envs in one process", "steps/s", "vs one", "steps/CPU-s", "vs one (CPU)"]
    print_table("Envs in one process vs one env", [*header, "target", "result"], rows)


def _scaling_cells(entry: dict[str, Any], single: dict[str, Any]) -> list[str]:
    wall, cpu = entry["steps_per_s"], entry.get("steps_per_cpu_s", 0.0)
    cpu_single = single.get("steps_per_cpu_s", 0.0)
    cpu_ratio = f"{cpu / cpu_single:.2f}x" if cpu and cpu_single else "n/a"
    return [f"{wall:,.0f}", f"{wall / single['steps_per_s']:.2f}x", f"{cpu:,.0f}", cpu_ratio]


def report_tinycarlo(tinycarlo: dict[str, Any]) -> None:
    """tinyrace (one 120x160 camera) over tinycarlo 1.1, per tinycarlo example."""
    if "error" in tinycarlo:
        print(f"\ntinycarlo 1.1: {tinycarlo['error']}")
        return
    names = [k.removeprefix("tinycarlo_") for k in tinycarlo if k.startswith("tinycarlo_")]
    print(f"\ntinycarlo 1.1 ran in {tinycarlo.get('interpreter')}; both with one 120x160 camera")
    if any(name.startswith("tinycarlo:") for name in names):
        print("tinycarlo:<name> = tinycarlo's own example folders; the others are tinyrace's")
    else:
        print("tinyrace's example tracks only (tinycarlo's own: --tinycarlo-examples DIR)")
    rows = [
        ratio_row(
            f"{name}, 1 camera 120x160: tinyrace vs tinycarlo 1.1",
            tinycarlo.get(f"tinyrace_{name}"),
            tinycarlo.get(f"tinycarlo_{name}"),
            TARGETS["vs_tinycarlo"],
        )
        for name in names
    ]
    for name in names:  # tinycarlo's own loop: its car drives on off the image (see the script)
        free = (tinycarlo.get(f"tinycarlo_{name}") or {}).get("free")
        row = ratio_row(
            f"{name}, tinycarlo never ending off the image",
            tinycarlo.get(f"tinyrace_{name}"),
            free,
            0,
        )
        rows.append([*row[:2], "", ""])
    print_table("Image tracks vs tinycarlo 1.1", ["measure", "value", "target", "result"], rows)


def timed(steppers: dict[str, Stepper], budget: Budget) -> dict[str, Any]:
    """Interleaved timings as JSON-ready dicts; closes the envs."""
    try:
        timings = interleave(steppers, budget.seconds, budget.rounds, budget.warmup)
        return {name: timing.as_dict() for name, timing in timings.items()}
    finally:
        for stepper in steppers.values():
            stepper.close()


def measure_rss(generated_dir: Path) -> dict[str, Any]:
    """Peak RSS of one env of each kind, each in a fresh process."""
    kinds: dict[str, dict[str, Any]] = {
        "baseline_imports": {"kind": "baseline"},
        "tinyrace": {"kind": "tinyrace"},
        "carracing_v3": {"kind": "gym", "id": "CarRacing-v3"},
        "envpool": {"kind": "envpool"},
    }
    for name in EXAMPLE_TRACKS:
        kinds[name] = {"kind": "image", "folder": str(TRACKS_DIR / name)}
    for name in GENERATED_SIZES:
        kinds[name] = {"kind": "image", "folder": str(generated_dir / name)}
    results: dict[str, Any] = {name: rss_in_subprocess(spec) for name, spec in kinds.items()}
    width, height = GENERATED_SIZES[BIG]
    results[f"{BIG}_image_bytes"] = width * height * 3  # decoded BGR
    return results


# Linux keeps a process's peak RSS across exec, and a child's address space starts as a
# copy of its parent's: a child started from this (large) process would report at least
# this process's peak. A tiny launcher in between starts the measured process afresh.
_LAUNCHER = "import subprocess, sys; sys.exit(subprocess.call(sys.argv[1:]))"


def rss_in_subprocess(spec: dict[str, Any]) -> Any:
    """{"ru_maxrss": bytes, "vm_hwm": bytes} of a fresh process running ``rss_child(spec)``."""
    child = [sys.executable, str(Path(__file__).resolve()), "--rss-child", json.dumps(spec)]
    command = [sys.executable, "-c", _LAUNCHER, *child]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600)
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines() or [f"exit code {done.returncode}"]
        if spec["kind"] == "envpool" and ("ImportError" in lines[-1] or "No module" in lines[-1]):
            return "not installed"
        return f"unavailable: {lines[-1]}"
    return json.loads(done.stdout.strip().splitlines()[-1])


def rss_child(spec: dict[str, Any]) -> None:
    """In a fresh process: build the env, reset, step RSS_STEPS times, print the peak RSS."""
    import pymunk  # noqa: F401  (part of the baseline, with gymnasium, numpy and cv2)

    kind = spec["kind"]
    if kind != "baseline":
        make: dict[str, Callable[[], Any]] = {
            "tinyrace": make_tinyrace,
            "gym": lambda: gym.make(spec["id"]),
            "envpool": make_envpool,
            "image": lambda: make_image_track(spec["folder"]),
        }
        with quiet_gym_warnings():
            pool = kind == "envpool"
            Stepper(make[kind](), auto_reset=pool, add_batch_axis=pool).take(RSS_STEPS)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB
    with open("/proc/self/status") as status:  # cross-check: this address space's peak
        hwm = next(int(line.split()[1]) * 1024 for line in status if line.startswith("VmHWM"))
    print(json.dumps({"ru_maxrss": peak, "vm_hwm": hwm}))


# -- the run ----------------------------------------------------------------------------------
def drawing_threads(threads: int) -> None:
    """cv2's threads for this process and for the processes it starts (tinycarlo, RSS
    children, vector workers), which read ``OPENCV_FOR_THREADS_NUM``."""
    os.environ["OPENCV_FOR_THREADS_NUM"] = str(threads)
    cv2.setNumThreads(threads)


def machine() -> dict[str, Any]:
    """Where and on what the figures were taken."""
    versions = {}
    for module in ("gymnasium", "numpy", "cv2", "pymunk", "numba", "envpool", "tinyrace"):
        try:
            imported = __import__(module)
            versions[module] = getattr(imported, "__version__", None) or imported.version
        except Exception as error:
            versions[module] = unavailable(error)
    git = subprocess.run(
        ["git", "-C", str(ROOT), "describe", "--always", "--dirty"], capture_output=True, text=True
    )
    return {
        "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "usable_cpus": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "load_average": os.getloadavg(),  # other work on the machine skews absolute figures
        "python": sys.version.split()[0],
        "versions": versions,
        "cv2_threads": cv2.getNumThreads(),
        "git": git.stdout.strip() or None,
    }


def guarded(name: str, measure: Callable[..., dict[str, Any]], *args: Any) -> dict[str, Any]:
    """Run one measurement; a crash becomes an entry in the results, not the end of the run."""
    print(f"measuring {name} ...", file=sys.stderr, flush=True)
    start = time.perf_counter()
    try:
        result = measure(*args)
    except Exception as error:
        traceback.print_exc()
        result = {"error": unavailable(error)}
    print(f"  done in {time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)
    return result


def run(budget: Budget, own_examples: Path | None = None) -> dict[str, Any]:
    """Every measurement, in one process (RSS in fresh ones), as a JSON-ready dict."""
    results: dict[str, Any] = {"machine": machine(), "budget": asdict(budget), "targets": TARGETS}
    with tempfile.TemporaryDirectory(prefix="tinyrace-bench-") as tmp, quiet_gym_warnings():
        generated = Path(tmp)
        for name, (width, height) in GENERATED_SIZES.items():
            write_generated_track(generated / name, width, height)
        results["throughput"] = guarded("throughput", measure_throughput, budget)
        results["reset"] = guarded("reset time", measure_reset, budget)
        results["image_tracks"] = guarded("image tracks", measure_image_tracks, budget, generated)
        results["track_sources"] = guarded("metric tracks", measure_track_sources, budget)
        results["vector"] = guarded("vector envs", measure_vector, budget)
        results["vector_scaling"] = guarded(
            "envs in one process (1..32)", measure_vector_scaling, budget
        )
        results["tinycarlo"] = guarded(
            "tinycarlo 1.1 (subprocess)", measure_tinycarlo, budget, generated, own_examples
        )
        results["vector_ceiling"] = guarded(
            "vector env ceiling (stand-in envs)",
            measure_vector_ceiling,
            budget,
            results["throughput"],
        )
        results["rss"] = guarded("peak RSS (fresh processes)", measure_rss, generated)
        results["sensors"] = guarded("sensors", measure_sensors_for, budget)
    return results


def measure_sensors_for(budget: Budget) -> dict[str, Any]:
    """Per-sensor cost (benchmarks/sensors.py): more steps for a longer budget."""
    return measure_sensors(steps=500 if budget is QUICK else 2000, reference_steps=5)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run, under a minute")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="JSON file to write")
    parser.add_argument("--sensors", action="store_true", help="only the per-sensor costs")
    parser.add_argument(
        "--tracks", action="store_true", help="only the metric tracks beside the procedural one"
    )
    parser.add_argument(
        "--scaling", action="store_true", help="only the 1..32 envs in one process table"
    )
    parser.add_argument(
        "--tinycarlo", action="store_true", help="only tinyrace vs tinycarlo 1.1 on image tracks"
    )
    parser.add_argument(
        "--tinycarlo-examples",
        type=Path,
        default=os.environ.get("TINYCARLO_EXAMPLES") or None,
        help="tinycarlo's own example_tracks folder (from its repository), timed too",
    )
    parser.add_argument(
        "--cv2-threads", type=int, default=1, help="cv2's threads (default 1: cost per core)"
    )
    parser.add_argument("--rss-child", help=argparse.SUPPRESS)  # internal: one RSS process
    args = parser.parse_args(argv)
    drawing_threads(args.cv2_threads)
    own_examples = Path(args.tinycarlo_examples) if args.tinycarlo_examples else None
    if args.rss_child:
        rss_child(json.loads(args.rss_child))
        return
    if args.sensors:
        with quiet_gym_warnings():
            results = {
                "machine": machine(),
                "sensors": measure_sensors_for(QUICK if args.quick else FULL),
                "lidar_compile": measure_compile(),
            }
        print_sensors(results["sensors"])
        print_compile(results["lidar_compile"])
        out = args.out.with_name("sensors.json") if args.out == DEFAULT_OUT else args.out
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(results, indent=2) + "\n")
        print(f"\nwrote {out}")
        return
    if args.scaling:
        with quiet_gym_warnings():
            scaling = measure_vector_scaling(QUICK if args.quick else FULL)
        report_scaling(scaling)
        return
    if args.tracks:
        with quiet_gym_warnings():
            tracks = measure_track_sources(QUICK if args.quick else FULL)
        print_track_sources(tracks)
        return
    if args.tinycarlo:
        with quiet_gym_warnings(), tempfile.TemporaryDirectory(prefix="tinyrace-bench-") as tmp:
            compared = measure_tinycarlo(QUICK if args.quick else FULL, Path(tmp), own_examples)
        report_tinycarlo(compared)
        return
    results = run(QUICK if args.quick else FULL, own_examples)
    report(results, RSS_STEPS)
    report_informational(results)
    if "error" not in results["sensors"]:
        print_sensors(results["sensors"])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n")
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
