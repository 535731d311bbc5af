"""Speed and memory of tinyrace beside Gymnasium's CarRacing-v3 and EnvPool, in one run.

Usage::

    python benchmarks/run.py                   # a few seconds per case (about 2-3 minutes)
    python benchmarks/run.py --quick           # smoke run (about 1 minute)
    python benchmarks/run.py --out FILE.json   # default: benchmarks/results/latest.json

Every case steps one env with seeded random actions (drawn up front, so drawing
them is not timed) and takes the observation of every step; an env whose
episode ends is reset inside the timed loop, as a training loop would. Each
timing follows a warm-up, and cases that are compared are timed in interleaved
rounds so that they share the machine's conditions. Measured:

- steps/s of ``tinyrace/CarRacing-v0`` (``gym.make``, wrappers included), of
  Gymnasium's ``CarRacing-v3`` and of EnvPool's ``CarRacing-v3`` (1 env, 1 thread;
  reported as not installed when envpool cannot be imported);
- reset time of tinyrace and CarRacing-v3: mean over seeded resets [ms];
- steps/s on the image tracks under ``example_tracks/`` with one 120x160 camera
  and with three, and on a generated 6000x3000 track beside a 1000x1000 one;
  a case that cannot run yet is reported as ``unavailable: <error>``;
- peak RSS (``ru_maxrss``) of one env of each kind, each in a fresh subprocess,
  after creating it, a reset and 200 steps; beside the RSS of a subprocess that
  only imports gymnasium, numpy, cv2 and pymunk;
- ``SyncVectorEnv`` and ``AsyncVectorEnv`` (2 envs, 2 workers) env-steps/s of
  ``tinyrace/CarRacing-v0`` against one env's steps/s.

It prints the targets with PASS/FAIL, then the raw figures, and writes every
figure as JSON. Memory figures are in MB of 10^6 bytes.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
import yaml

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE_TRACKS = ("segmented", "formula_student", "carolo_cup")
DEFAULT_OUT = ROOT / "benchmarks" / "results" / "latest.json"
SEED = 0
ACTION_BLOCK = 4096  # pre-drawn actions, cycled
RSS_STEPS = 200
MB = 1e6  # [bytes]

TARGETS = {
    "vs_carracing_v3": 30.0,  # [x] tinyrace steps/s over CarRacing-v3's
    "vs_envpool": 4.0,  # [x] tinyrace steps/s over EnvPool's
    "reset_ratio": 1.0,  # [x] CarRacing-v3 reset time over tinyrace's: no slower
    "image_steps_per_s": 3000.0,  # [steps/s] image track, one 120x160 camera
    "size_tolerance": 0.20,  # 6000x3000 steps/s within 20% of 1000x1000's
    "rss_image_factor": 3.0,  # peak RSS <= 3 x decoded image bytes + 80 MB
    "rss_allowance": 80 * MB,  # [bytes]
    "async_ratio": 1.6,  # [x] AsyncVectorEnv(2) env-steps/s over one env's
}

FRONT = {"id": "front", "resolution": [120, 160], "roi": [360, 480]}
ONE_CAMERA = [FRONT]
THREE_CAMERAS = [
    FRONT,
    {"id": "left", "resolution": [120, 160], "roi": [360, 480], "yaw": -90},
    {"id": "rear", "resolution": [120, 160], "roi": [360, 480], "yaw": 180},
]
GENERATED_SIZES = {"generated_1000x1000": (1000, 1000), "generated_6000x3000": (6000, 3000)}


@dataclass(frozen=True)
class Budget:
    """How long each case runs."""

    seconds: float  # [s] timed per case, split over the rounds
    rounds: int  # interleaved rounds per comparison
    warmup: float  # [s] stepped before timing
    resets: int  # seeded resets timed per env


FULL = Budget(seconds=4.0, rounds=4, warmup=0.5, resets=20)
QUICK = Budget(seconds=0.6, rounds=2, warmup=0.15, resets=5)


# -- stepping ---------------------------------------------------------------------------------
@dataclass
class Timing:
    """Steps taken (env-steps for batches) and wall time spent, summed over rounds."""

    steps: int = 0
    seconds: float = 0.0  # [s]
    resets: int = 0  # episodes ended and reset inside the timed loop
    rounds: list[float] = field(default_factory=list)  # [steps/s] of each round

    @property
    def rate(self) -> float:
        """[steps/s]"""
        return self.steps / self.seconds if self.seconds else 0.0

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "steps_per_s": self.rate}


class Stepper:
    """Steps an env, a vector env or an EnvPool batch with pre-drawn seeded random actions.

    ``batch`` envs advance per call; ``auto_reset`` envs reset themselves, others are
    reset here when an episode ends; ``add_batch_axis`` wraps single actions for EnvPool.
    """

    def __init__(
        self, env: Any, *, batch: int = 1, auto_reset: bool = False, add_batch_axis: bool = False
    ):
        self.env, self.batch, self.auto_reset = env, batch, auto_reset
        env.action_space.seed(SEED)
        actions = [env.action_space.sample() for _ in range(ACTION_BLOCK)]
        self.actions = [a[None] for a in actions] if add_batch_axis else actions
        self.index = 0
        env.reset(seed=SEED) if not add_batch_axis else env.reset()

    def run(self, seconds: float) -> Timing:
        env, actions, n = self.env, self.actions, len(self.actions)
        steps = resets = 0
        start = time.perf_counter()
        end = start + seconds
        while True:
            _, _, terminated, truncated, _ = env.step(actions[self.index % n])
            self.index += 1
            steps += 1
            if not self.auto_reset and (terminated or truncated):
                env.reset()
                resets += 1
            now = time.perf_counter()
            if now >= end:
                break
        return Timing(steps * self.batch, now - start, resets)

    def take(self, steps: int) -> None:
        """``steps`` calls, untimed."""
        for _ in range(steps):
            self.run(0.0)  # a zero budget still takes one step

    def close(self) -> None:
        self.env.close()


def interleave(steppers: dict[str, Stepper], budget: Budget) -> dict[str, Timing]:
    """Warm each stepper up, then time them in rounds, rotating who goes first."""
    for stepper in steppers.values():
        stepper.run(budget.warmup)
    totals = {name: Timing() for name in steppers}
    names = list(steppers)
    for round_index in range(budget.rounds):
        shift = round_index % len(names)
        for name in names[shift:] + names[:shift]:
            timing = steppers[name].run(budget.seconds / budget.rounds)
            total = totals[name]
            total.steps, total.seconds = total.steps + timing.steps, total.seconds + timing.seconds
            total.resets += timing.resets
            total.rounds.append(timing.rate)
    return totals


def unavailable(error: BaseException) -> str:
    message = str(error).strip().splitlines()[0] if str(error).strip() else ""
    return f"unavailable: {type(error).__name__}: {message}"


@contextmanager
def quiet_gym_warnings() -> Iterator[None]:
    """Gymnasium's checkers warn once per env (e.g. float32 casts); keep the table readable."""
    level = gym.logger.min_level
    gym.logger.min_level = gym.logger.ERROR
    try:
        yield
    finally:
        gym.logger.min_level = level


# -- env factories ----------------------------------------------------------------------------
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

    Colours (BGR): white road edges, green trajectory, red obstacle box (reward -1)
    a quarter lap ahead of the spawn. The car spawns on the trajectory, heading along it.
    """
    folder.mkdir(parents=True, exist_ok=True)
    image = np.zeros((height, width, 3), np.uint8)
    margin, half_road = 180, 120  # [px]
    center = (width // 2, height // 2)
    a, b = width // 2 - margin, height // 2 - margin  # [px] trajectory radii
    for offset in (-half_road, half_road):
        cv2.ellipse(image, center, (a + offset, b + offset), 0, 0, 360, (255, 255, 255), 8)
    cv2.ellipse(image, center, (a, b), 0, 0, 360, (0, 255, 0), 2)
    box = 30  # [px] half side
    cv2.rectangle(
        image, (center[0] - box, center[1] + b - box), (center[0] + box, center[1] + b + box),
        (0, 0, 255), -1,
    )  # fmt: skip
    cv2.imwrite(str(folder / "track.png"), image)
    config = {
        "sim": {"fps": 30, "render_realtime": False, "step_limit": 1000},
        "reward_design": {
            "color_obstacles": [{"color": [0, 0, 255], "reward": -1}],
            "cross_track_error": {"use_cte": True, "trajectory_color": [0, 255, 0]},
        },
        "car": {"wheelbase": 150, "track_width": 100, "velocity": 400, "max_steering_change": 180},
        "cameras": ONE_CAMERA,
        # rightmost point of the ellipse; heading pi/2 = +y on screen, along the loop
        "tracks": [{"image": "track.png", "spawns": [[center[0] + a, center[1], math.pi / 2]]}],
    }
    (folder / "track.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    return folder


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
    for name, timing in interleave(steppers, budget).items():
        results[name] = timing.as_dict()
        steppers[name].close()
    return results


def measure_reset(budget: Budget) -> dict[str, Any]:
    """Mean time of a seeded reset [ms], tinyrace and CarRacing-v3 alternating."""
    envs = {"tinyrace": make_tinyrace(), "carracing_v3": gym.make("CarRacing-v3")}
    times: dict[str, list[float]] = {name: [] for name in envs}
    for env in envs.values():
        env.reset(seed=SEED)  # warm-up (and the env checker's first-reset checks)
    for seed in range(1, budget.resets + 1):
        for name, env in envs.items():
            start = time.perf_counter()
            env.reset(seed=seed)
            times[name].append((time.perf_counter() - start) * 1e3)
    for env in envs.values():
        env.close()
    return {
        name: {"mean_ms": float(np.mean(t)), "median_ms": float(np.median(t)), "all_ms": t}
        for name, t in times.items()
    }


def image_track_cases(generated_dir: Path) -> dict[str, Callable[[], gym.Env]]:
    """Every image-track case by name: example tracks x (1, 3) cameras, and generated tracks."""
    cases: dict[str, Callable[[], gym.Env]] = {}
    for name in EXAMPLE_TRACKS:
        folder = ROOT / "example_tracks" / name
        cases[f"{name}_1cam"] = lambda f=folder: make_image_track(f, ONE_CAMERA)
        cases[f"{name}_3cam"] = lambda f=folder: make_image_track(f, THREE_CAMERAS)
    for name in GENERATED_SIZES:
        cases[name] = lambda f=generated_dir / name: make_image_track(f, ONE_CAMERA)
    return cases


def measure_image_tracks(budget: Budget, generated_dir: Path) -> dict[str, Any]:
    """steps/s of each image-track case that runs; the others say why they cannot."""
    results: dict[str, Any] = {}
    steppers: dict[str, Stepper] = {}
    for name, make in image_track_cases(generated_dir).items():
        try:
            stepper = Stepper(make())
            stepper.run(0.01)  # fail here, not in the middle of the timed rounds
            steppers[name] = stepper
        except Exception as error:
            results[name] = unavailable(error)
    for name, timing in interleave(steppers, budget).items():
        results[name] = timing.as_dict()
        steppers[name].close()
    return {name: results[name] for name in image_track_cases(generated_dir)}


def measure_rss(generated_dir: Path) -> dict[str, Any]:
    """Peak RSS of one env of each kind, each in a fresh subprocess."""
    kinds: dict[str, dict[str, Any]] = {
        "baseline_imports": {"kind": "baseline"},
        "tinyrace": {"kind": "tinyrace"},
        "carracing_v3": {"kind": "gym", "id": "CarRacing-v3"},
        "envpool": {"kind": "envpool"},
    }
    for name in EXAMPLE_TRACKS:
        kinds[name] = {"kind": "image", "folder": str(ROOT / "example_tracks" / name)}
    for name in GENERATED_SIZES:
        kinds[name] = {"kind": "image", "folder": str(generated_dir / name)}
    results: dict[str, Any] = {name: rss_in_subprocess(spec) for name, spec in kinds.items()}
    width, height = GENERATED_SIZES["generated_6000x3000"]
    image_bytes = width * height * 3
    results["generated_6000x3000_image_bytes"] = image_bytes
    results["generated_6000x3000_target_bytes"] = (
        TARGETS["rss_image_factor"] * image_bytes + TARGETS["rss_allowance"]
    )
    return results


def rss_in_subprocess(spec: dict[str, Any]) -> Any:
    command = [sys.executable, str(Path(__file__).resolve()), "--rss-child", json.dumps(spec)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600)
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines() or [f"exit code {done.returncode}"]
        if "ImportError" in lines[-1] or "ModuleNotFoundError" in lines[-1]:
            if spec["kind"] == "envpool":
                return "not installed"
        return f"unavailable: {lines[-1]}"
    return json.loads(done.stdout.strip().splitlines()[-1])["peak_rss_bytes"]


def rss_child(spec: dict[str, Any]) -> None:
    """In a fresh process: build the env, reset, step RSS_STEPS times, print the peak RSS."""
    import pymunk  # noqa: F401  (part of the baseline)

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
    print(json.dumps({"peak_rss_bytes": peak}))


def measure_vector(budget: Budget) -> dict[str, Any]:
    """Env-steps/s of one env, SyncVectorEnv(2) and AsyncVectorEnv(2 workers), interleaved."""
    makers = [make_tinyrace, make_tinyrace]
    steppers = {"single": Stepper(make_tinyrace())}
    results: dict[str, Any] = {}
    for name, build in (
        ("sync_2", lambda: gym.vector.SyncVectorEnv(makers)),
        ("async_2", lambda: gym.vector.AsyncVectorEnv(makers)),
    ):
        try:
            steppers[name] = Stepper(build(), batch=2, auto_reset=True)
        except Exception as error:
            results[name] = unavailable(error)
    for name, timing in interleave(steppers, budget).items():
        results[name] = timing.as_dict()
        steppers[name].close()
    return results


# -- targets and tables -----------------------------------------------------------------------
def rate_of(entry: Any) -> float | None:
    return entry["steps_per_s"] if isinstance(entry, dict) and "steps_per_s" in entry else None


def verdict(ok: bool | None) -> str:
    return "n/a" if ok is None else ("PASS" if ok else "FAIL")


def why_missing(entry: Any) -> str:
    return entry if isinstance(entry, str) else "unavailable (see JSON)"


def ratio_row(label: str, a: Any, b: Any, target: float, unit: str = "steps/s") -> list[str]:
    """``a / b`` of two timings against ``>= target``."""
    ra, rb = rate_of(a), rate_of(b)
    if ra is None or rb is None:
        return [label, why_missing(a if ra is None else b), f">= {target:g}x", "n/a"]
    ratio = ra / rb
    value = f"{ratio:.2f}x ({ra:,.0f} vs {rb:,.0f} {unit})"
    return [label, value, f">= {target:g}x", verdict(ratio >= target)]


def target_rows(results: dict[str, Any]) -> list[list[str]]:
    """One row per target: measure, value, target, PASS/FAIL/n/a."""
    speed, reset, image = results["throughput"], results["reset"], results["image_tracks"]
    rss, vector = results["rss"], results["vector"]
    rows = [
        ratio_row("tinyrace vs CarRacing-v3", speed.get("tinyrace"), speed.get("carracing_v3"),
                  TARGETS["vs_carracing_v3"]),
        ratio_row("tinyrace vs EnvPool (1 env, 1 thread)", speed.get("tinyrace"),
                  speed.get("envpool"), TARGETS["vs_envpool"]),
    ]  # fmt: skip
    if "tinyrace" in reset and "carracing_v3" in reset:
        mine, theirs = reset["tinyrace"]["mean_ms"], reset["carracing_v3"]["mean_ms"]
        value = f"{theirs / mine:.2f}x ({mine:.1f} vs {theirs:.1f} ms)"
        ok = theirs / mine >= TARGETS["reset_ratio"]
        rows.append(["reset: CarRacing-v3 time / tinyrace's", value, ">= 1x (no slower)",
                     verdict(ok)])  # fmt: skip
    else:
        rows.append(["reset: CarRacing-v3 time / tinyrace's", why_missing(reset), ">= 1x", "n/a"])
    floor = TARGETS["image_steps_per_s"]
    for name in EXAMPLE_TRACKS:
        r = rate_of(image.get(f"{name}_1cam"))
        value = f"{r:,.0f} steps/s" if r is not None else why_missing(image.get(f"{name}_1cam"))
        ok = None if r is None else r >= floor
        rows.append([f"image track {name}, 1 camera", value, f">= {floor:g} steps/s", verdict(ok)])
    big, small = image.get("generated_6000x3000"), image.get("generated_1000x1000")
    tolerance = TARGETS["size_tolerance"]
    row = ratio_row("image track 6000x3000 vs 1000x1000", big, small, 0.0)
    if rate_of(big) is not None and rate_of(small) is not None:
        row[3] = verdict(abs(rate_of(big) / rate_of(small) - 1.0) <= tolerance)
    row[2] = f"within {tolerance:.0%}"
    rows.append(row)
    rows.append(rss_row(rss))
    rows.append(ratio_row("AsyncVectorEnv(2) vs one env", vector.get("async_2"),
                          vector.get("single"), TARGETS["async_ratio"], "env-steps/s"))  # fmt: skip
    return rows


def rss_row(rss: dict[str, Any]) -> list[str]:
    label = "peak RSS, 6000x3000 image track"
    peak, target = rss.get("generated_6000x3000"), rss.get("generated_6000x3000_target_bytes")
    image_mb = rss.get("generated_6000x3000_image_bytes", 0) / MB
    target_text = (
        f"<= {target / MB:.0f} MB (3 x {image_mb:.0f} MB + 80 MB)" if target else "n/a"
    )
    if not isinstance(peak, int):
        return [label, why_missing(peak), target_text, "n/a"]
    return [label, f"{peak / MB:.0f} MB", target_text, verdict(peak <= target)]


def detail_rows(results: dict[str, Any]) -> list[list[str]]:
    """Every steps/s figure: section, case, steps/s, ms per step, resets during timing."""
    rows = []
    for section in ("throughput", "image_tracks", "vector"):
        for name, entry in results[section].items():
            r = rate_of(entry)
            if r is None:
                rows.append([section, name, why_missing(entry), "", ""])
            else:
                rows.append([section, name, f"{r:,.0f}", f"{1e3 / r:.3f}", str(entry["resets"])])
    return rows


def memory_rows(rss: dict[str, Any]) -> list[list[str]]:
    baseline = rss.get("baseline_imports")
    rows = []
    for name, peak in rss.items():
        if name.endswith("_bytes"):
            continue
        if not isinstance(peak, int):
            rows.append([name, why_missing(peak), ""])
            continue
        extra = f"{(peak - baseline) / MB:+.0f}" if isinstance(baseline, int) else ""
        rows.append([name, f"{peak / MB:.0f}", extra])
    return rows


def print_table(title: str, headers: list[str], rows: list[list[str]], width: int = 72) -> None:
    """A plain-text table; cells longer than ``width`` are cut (the JSON keeps them whole)."""
    cells = [[c if len(c) <= width else c[: width - 3] + "..." for c in row] for row in rows]
    widths = [max(len(r[i]) for r in [headers, *cells]) for i in range(len(headers))]
    print(f"\n{title}")
    print("  ".join(h.ljust(w) for h, w in zip(headers, widths, strict=True)))
    print("  ".join("-" * w for w in widths))
    for row in cells:
        print("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip())


# -- the run ----------------------------------------------------------------------------------
def machine() -> dict[str, Any]:
    """Where and on what the figures were taken."""
    versions = {}
    for module in ("gymnasium", "numpy", "cv2", "pymunk", "envpool", "tinyrace"):
        try:
            versions[module] = __import__(module).__version__
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
        "python": sys.version.split()[0],
        "versions": versions,
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
    print(f"  {time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)
    return result


def run(budget: Budget) -> dict[str, Any]:
    results: dict[str, Any] = {"machine": machine(), "budget": asdict(budget), "targets": TARGETS}
    with tempfile.TemporaryDirectory(prefix="tinyrace-bench-") as tmp, quiet_gym_warnings():
        generated = Path(tmp)
        for name, (width, height) in GENERATED_SIZES.items():
            write_generated_track(generated / name, width, height)
        results["throughput"] = guarded("throughput", measure_throughput, budget)
        results["reset"] = guarded("reset time", measure_reset, budget)
        results["image_tracks"] = guarded("image tracks", measure_image_tracks, budget, generated)
        results["rss"] = guarded("peak RSS (subprocesses)", measure_rss, generated)
        results["vector"] = guarded("vector envs", measure_vector, budget)
    return results


def report(results: dict[str, Any]) -> None:
    m = results["machine"]
    print(f"\ntinyrace benchmark  {m['time']}  git {m['git']}  python {m['python']}")
    print(f"{m['processor']}, {m['usable_cpus']} usable CPUs; {m['platform']}")
    print_table("Targets", ["measure", "value", "target", "result"], target_rows(results))
    print_table(
        "Steps (random actions, observation every step; resets inside the timing)",
        ["section", "case", "steps/s", "ms/step", "resets"],
        detail_rows(results),
    )
    reset = results["reset"]
    print_table(
        "Reset (seeded, mean)",
        ["env", "mean ms", "median ms"],
        [
            [name, f"{r['mean_ms']:.2f}", f"{r['median_ms']:.2f}"]
            for name, r in reset.items()
            if isinstance(r, dict)
        ],
    )
    print_table(
        f"Peak RSS after make, reset and {RSS_STEPS} steps (fresh process each)",
        ["kind", "MB", "MB over baseline"],
        memory_rows(results["rss"]),
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run, about a minute")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="JSON file to write")
    parser.add_argument("--rss-child", help=argparse.SUPPRESS)  # internal: one RSS subprocess
    args = parser.parse_args(argv)
    if args.rss_child:
        rss_child(json.loads(args.rss_child))
        return
    results = run(QUICK if args.quick else FULL)
    report(results)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n")
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
