"""Calibrated perspective cameras: intrinsics, plumb_bob distortion and ROS camera_info files.

A ``perspective_camera`` takes one of: ``fov`` (the default, 90 deg), ``intrinsics`` [fx, fy,
cx, cy] [px] (with an optional ``distortion`` k1, k2, p1, p2, k3: OpenCV's plumb_bob order),
or ``camera_info``: a ROS camera_info YAML as camera_calibration writes it (``image_width``,
``image_height``, ``camera_matrix`` {rows: 3, cols: 3, data: [fx, 0, cx, 0, fy, cy, 0, 0,
1]}, ``distortion_model: plumb_bob``, ``distortion_coefficients`` {data: [k1, k2, p1, p2,
k3]}). ``with_camera_info`` reads each file once, when the config is loaded, into the
entry's ``intrinsics`` and ``distortion``, scaled to the entry's ``resolution`` when the
file's image size differs (the camera matrix scales with the image; the distortion, in
normalised coordinates, does not). Pixel centres sit on integer coordinates, as in OpenCV.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tinyrace.config.paths import inside_folder
from tinyrace.config.schema import EnvConfig
from tinyrace.config.sensors import PerspectiveCameraConfig, SensorConfig
from tinyrace.config.yaml_file import parse_yaml, read_bytes
from tinyrace.errors import ConfigError, Problem

MODELS = ("plumb_bob", "rational_polynomial")  # accepted names; only 5 coefficients used
MAX_BYTES = 1 << 20  # [bytes] a camera_info file at most


def intrinsics_problems(camera: PerspectiveCameraConfig) -> list[tuple[str, Any, str]]:
    """(key, value, allowed) of each inconsistency of a camera entry's calibration knobs."""
    return camera.calibration_problems()


def read_camera_info(
    path: Path, source: str, where: str
) -> tuple[
    tuple[int, int], tuple[float, float, float, float], tuple[float, float, float, float, float]
]:
    """((width, height) [px], (fx, fy, cx, cy) [px], (k1, k2, p1, p2, k3)) of a camera_info
    YAML; every problem names the file and key."""
    try:  # a regular file only, checked before a byte is read (a FIFO would block)
        text = read_bytes(path, MAX_BYTES, "a camera_info YAML").decode("utf-8")
    except ConfigError as error:
        allowed = f"expected a readable camera_info YAML: {error.problems[0].allowed}"
        raise ConfigError(Problem(source, where, str(path), allowed)) from None
    except UnicodeDecodeError as error:
        allowed = f"expected a camera_info YAML of UTF-8 text (byte {error.start} is not)"
        raise ConfigError(Problem(source, where, str(path), allowed)) from None
    data = parse_yaml(text, str(path))
    if not isinstance(data, dict):
        raise ConfigError(Problem(str(path), "", data, "expected a camera_info mapping"))
    problems: list[Problem] = []

    def bad(key: str, value: Any, allowed: str) -> None:
        problems.append(Problem(str(path), key, value, allowed))

    size: list[int] = []
    for key in ("image_width", "image_height"):
        value = data.get(key)
        if not (isinstance(value, int) and not isinstance(value, bool) and value > 0):
            bad(key, value, "expected a whole number of pixels > 0")
        else:
            size.append(value)
    matrix = _data(data.get("camera_matrix"), 9)
    if matrix is None:
        bad(
            "camera_matrix",
            data.get("camera_matrix"),
            "expected {rows: 3, cols: 3, data: [9 numbers]}",
        )
    else:
        fx, skew, cx, zero1, fy, cy, zero2, zero3, one = matrix
        if not (fx > 0 and fy > 0 and skew == 0 and zero1 == zero2 == zero3 == 0 and one == 1):
            allowed = "expected [fx, 0, cx, 0, fy, cy, 0, 0, 1] with fx, fy > 0 (no skew)"
            bad("camera_matrix.data", matrix, allowed)
    model = data.get("distortion_model", "plumb_bob")
    if model not in MODELS:
        bad("distortion_model", model, "expected plumb_bob (k1, k2, p1, p2, k3)")
    raw = data.get("distortion_coefficients")
    coefficients = _data(raw, None) if raw is not None else [0.0] * 5
    if coefficients is None or len(coefficients) < 4:
        bad(
            "distortion_coefficients",
            raw,
            "expected {rows: 1, cols: 5, data: [k1, k2, p1, p2, k3]}",
        )
    elif model == "plumb_bob" and len(coefficients) != 5:
        bad("distortion_coefficients.data", coefficients, "expected 5 numbers: k1, k2, p1, p2, k3")
    elif any(coefficients[5:]):
        bad("distortion_coefficients.data", coefficients, "expected at most 5 nonzero numbers")
    if problems:
        raise ConfigError(problems)
    assert matrix is not None and coefficients is not None
    k1, k2, p1, p2, k3 = (*coefficients[:5], 0.0, 0.0, 0.0, 0.0, 0.0)[:5]
    fx, _, cx, _, fy, cy, *_ = matrix
    return (size[0], size[1]), (fx, fy, cx, cy), (k1, k2, p1, p2, k3)


def _data(entry: Any, count: int | None) -> list[float] | None:
    """The ``data`` numbers of a matrix entry ({rows, cols, data}), ``count`` of them."""
    if not isinstance(entry, dict):
        return None
    numbers = entry.get("data")
    if not isinstance(numbers, list) or (count is not None and len(numbers) != count):
        return None
    if not all(isinstance(n, (int, float)) and not isinstance(n, bool) for n in numbers):
        return None
    if not all(math.isfinite(n) for n in numbers):
        return None
    return [float(n) for n in numbers]


def scaled(
    intrinsics: tuple[float, float, float, float], size: tuple[int, int], to: tuple[int, int]
) -> tuple[float, float, float, float]:
    """[fx, fy, cx, cy] of an image ``size`` (w, h) resampled to ``to`` (w, h): pixel
    centres on integers, so a centre c moves to (c + 0.5) s - 0.5."""
    fx, fy, cx, cy = intrinsics
    sx, sy = to[0] / size[0], to[1] / size[1]
    return fx * sx, fy * sy, (cx + 0.5) * sx - 0.5, (cy + 0.5) * sy - 0.5


def with_camera_info(config: EnvConfig, source: str, base_dir: Path) -> EnvConfig:
    """``config`` with every camera_info file read into its entry's intrinsics and
    distortion (scaled to the entry's resolution): the shared sensors' and each race car's."""
    problems: list[Problem] = []
    sensors = _read_infos(config, config.sensors, config.sensor_key, source, base_dir, problems)
    cars = []
    for index, car in enumerate(config.race.cars):
        if car.sensors is not None:  # as written (no cameras)

            def key(i: int, at: str = f"race.cars[{index}].") -> str:
                return f"{at}sensors[{i}]"

            own = _read_infos(config, car.sensors, key, source, base_dir, problems)
            car = dataclasses.replace(car, sensors=own)
        cars.append(car)
    if problems:
        raise ConfigError(problems)
    race = dataclasses.replace(config.race, cars=tuple(cars))
    return dataclasses.replace(config, sensors=sensors, race=race)


def _read_infos(
    config: EnvConfig,
    entries: tuple[SensorConfig, ...],
    key: Callable[[int], str],
    source: str,
    base_dir: Path,
    problems: list[Problem],
) -> tuple[SensorConfig, ...]:
    """``entries`` with their camera_info files read; ``key(i)``: entry i's key as written."""
    sensors = list(entries)
    for index, entry in enumerate(sensors):
        if not isinstance(entry, PerspectiveCameraConfig) or entry.camera_info is None:
            continue
        where = f"{key(index)}.camera_info"
        try:
            path = inside_folder(
                entry.camera_info, base_dir, config.files.paths_outside_folder, source, where
            )
            size, intrinsics, distortion = read_camera_info(path, source, where)
        except ConfigError as error:
            problems += error.problems
            continue
        height, width = entry.resolution
        intrinsics = scaled(intrinsics, size, (width, height))
        sensors[index] = dataclasses.replace(entry, intrinsics=intrinsics, distortion=distortion)
    return tuple(sensors)
