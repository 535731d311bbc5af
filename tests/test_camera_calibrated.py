"""Calibrated perspective cameras: intrinsics and plumb_bob distortion (given, or read from a
ROS camera_info YAML) put ground points where ``cv2.projectPoints`` does, within 1 px; bad
calibrations are ConfigErrors naming the file and key."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np
import pytest
import yaml

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.sensors.machinery.pinhole import Pinhole, car_to_world, render

SIZE = (640, 480)  # (width, height) [px]
MATRIX = (410.0, 405.0, 327.3, 236.8)  # fx, fy, cx, cy [px]
BARREL = (-0.28, 0.09, 0.0012, -0.0007, -0.012)  # k1, k2, p1, p2, k3
PER_METRE = 100.0  # [texture px per m]
ORIGIN = (-1.0, -5.0)  # [m] the texture's pixel (0, 0)


def dots() -> np.ndarray:
    """(N, 2) car-frame ground points (ahead, right) [m], a fan in front of the camera."""
    ahead, across = np.meshgrid(np.linspace(1.2, 3.6, 7), np.linspace(-0.5, 0.5, 9))
    return np.column_stack((ahead.ravel(), (ahead * across).ravel()))


def texture(points: np.ndarray) -> np.ndarray:
    """(1000, 1000) uint8 ground: a Gaussian dot (sigma 1.5 cm) at each car-frame point, the
    car at the world's origin facing +x (its right is -y)."""
    ys, xs = np.mgrid[0:1000, 0:1000].astype(np.float64)
    image = np.zeros((1000, 1000))
    for ahead, right in points:
        u, v = (ahead - ORIGIN[0]) * PER_METRE, (-right - ORIGIN[1]) * PER_METRE
        image = np.maximum(image, np.exp(-((xs - u) ** 2 + (ys - v) ** 2) / (2 * 1.5**2)))
    return np.round(image * 255).astype(np.uint8)


def centroids(image: np.ndarray, near: np.ndarray, half: int = 8) -> np.ndarray:
    """(N, 2) brightness-weighted centres [px] of the dots in windows around ``near``."""
    found = []
    for u, v in near:
        c, r = round(u), round(v)
        window = image[r - half : r + half + 1, c - half : c + half + 1].astype(np.float64)
        window = np.where(window > 0.2 * window.max(), window, 0.0)
        ys, xs = np.mgrid[r - half : r + half + 1, c - half : c + half + 1]
        found.append((float((window * xs).sum() / window.sum()),
                      float((window * ys).sum() / window.sum())))  # fmt: skip
    return np.array(found)


@pytest.mark.parametrize("distortion", [None, BARREL], ids=["pinhole", "plumb_bob"])
def test_rendered_ground_points_land_where_opencv_projects_them(distortion):
    camera = Pinhole(SIZE, math.radians(90), (0.0, 0.0, 1.0), pitch=math.radians(30),
                     yaw=math.radians(4), roll=math.radians(2), matrix=MATRIX,
                     distortion=distortion)  # fmt: skip
    points = dots()
    world_to_ground = np.array([[PER_METRE, 0, -ORIGIN[0] * PER_METRE],
                                [0, PER_METRE, -ORIGIN[1] * PER_METRE]])  # fmt: skip
    placed = car_to_world((0.0, 0.0), 0.0, False)
    image = render(camera, texture(points), world_to_ground, placed, (0,))
    # OpenCV: the camera frame (x right, y down, z ahead) is axes @ (p - position), p in the
    # car frame (ahead, right, up); OpenCV's rotation needs a right-handed object frame:
    # (ahead, left, up)
    fx, fy, cx, cy = MATRIX
    matrix = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])
    left_handed = np.diag([1.0, -1.0, 1.0])
    rvec, _ = cv2.Rodrigues(camera.axes @ left_handed)
    tvec = -camera.axes @ np.array(camera.position)
    ground = np.column_stack((points[:, 0], -points[:, 1], np.zeros(len(points))))
    coefficients = np.zeros(5) if distortion is None else np.array(distortion)
    expected, _ = cv2.projectPoints(ground, rvec, tvec, matrix, coefficients)
    expected = expected.reshape(-1, 2)
    inside = (
        (expected[:, 0] > 10) & (expected[:, 0] < SIZE[0] - 10)
        & (expected[:, 1] > 10) & (expected[:, 1] < SIZE[1] - 10)
    )  # fmt: skip
    assert inside.sum() >= 40
    error = np.hypot(*(centroids(image, expected[inside]) - expected[inside]).T)
    print(f"reprojection error [px]: median {np.median(error):.3f}, max {error.max():.3f}")
    assert error.max() < 1.0, error.max()  # [px]
    if distortion is not None:  # the distortion matters: the pinhole alone misses by far
        plain, _ = cv2.projectPoints(ground, rvec, tvec, matrix, np.zeros(5))
        assert np.hypot(*(plain.reshape(-1, 2) - expected).T)[inside].max() > 20


def camera_info(folder: Path, **changes) -> Path:
    fx, fy, cx, cy = MATRIX
    info = {
        "image_width": SIZE[0], "image_height": SIZE[1], "camera_name": "front",
        "camera_matrix": {"rows": 3, "cols": 3, "data": [fx, 0, cx, 0, fy, cy, 0, 0, 1]},
        "distortion_model": "plumb_bob",
        "distortion_coefficients": {"rows": 1, "cols": 5, "data": list(BARREL)},
        "rectification_matrix": {"rows": 3, "cols": 3, "data": [1, 0, 0, 0, 1, 0, 0, 0, 1]},
        "projection_matrix": {"rows": 3, "cols": 4,
                              "data": [fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0]},
    }  # fmt: skip
    info.update(changes)
    path = folder / "front.yaml"
    path.write_text(yaml.safe_dump(info))
    return path


def camera_env(folder: Path, **camera) -> gym.Env:
    entry = {"id": "front", "type": "perspective_camera", "resolution": [240, 320], **camera}
    config = yaml.safe_load((TRACKS_DIR / "f1tenth_loop" / "track.yaml").read_text())
    for name in ("map.yaml", "map.png", "raceline.csv"):
        (folder / name).write_bytes((TRACKS_DIR / "f1tenth_loop" / name).read_bytes())
    config.pop("cameras", None)
    config["sensors"] = [entry]
    (folder / "env.yaml").write_text(yaml.safe_dump(config))
    return gym.make("tinyrace/TinyRace-v0", config=str(folder / "env.yaml"))


def test_a_camera_info_file_sets_the_intrinsics_scaled_to_the_resolution(tmp_path):
    camera_info(tmp_path)
    env = camera_env(tmp_path, camera_info="front.yaml", pitch=25)
    observation, _ = env.reset(seed=0)
    assert observation["front"].shape == (240, 320, 3)
    pinhole = env.unwrapped.sensors[0].pinhole
    fx, fy, cx, cy = MATRIX
    expected = [[fx / 2, 0, (cx + 0.5) / 2 - 0.5], [0, fy / 2, (cy + 0.5) / 2 - 0.5], [0, 0, 1]]
    np.testing.assert_allclose(pinhole.intrinsics, expected)
    assert pinhole.distortion == BARREL and pinhole.distorted
    assert observation["front"].std() > 0  # the ground is seen


@pytest.mark.parametrize(
    ("camera", "info", "key", "says"),
    [
        ({"fov": 80, "intrinsics": list(MATRIX)}, None, "sensors[0].fov", "not both"),
        ({"camera_info": "front.yaml", "fov": 80}, {}, "sensors[0].fov", "not both"),
        ({"distortion": list(BARREL)}, None, "sensors[0].distortion", "needs intrinsics"),
        ({"intrinsics": [0, 400, 160, 120]}, None, "sensors[0].intrinsics", "fx, fy > 0"),
        ({"camera_info": "front.yaml"}, {"distortion_model": "equidistant"},
         "distortion_model", "plumb_bob"),
        ({"camera_info": "front.yaml"},
         {"camera_matrix": {"rows": 3, "cols": 3, "data": [400, 3, 160, 0, 400, 120, 0, 0, 1]}},
         "camera_matrix.data", "no skew"),
        ({"camera_info": "front.yaml"}, {"camera_matrix": {"rows": 2, "data": [1, 2]}},
         "camera_matrix", "9 numbers"),
        ({"camera_info": "front.yaml"},
         {"distortion_coefficients": {"rows": 1, "cols": 4, "data": [0.1, 0, 0, 0]}},
         "distortion_coefficients.data", "5 numbers"),
        ({"camera_info": "missing.yaml"}, None, "sensors[0].camera_info", "readable"),
    ],
)  # fmt: skip
def test_bad_calibrations_are_config_errors_naming_the_key(tmp_path, camera, info, key, says):
    if info is not None:
        camera_info(tmp_path, **info)
    with pytest.raises(ConfigError) as caught:
        camera_env(tmp_path, **camera)
    text = str(caught.value)
    assert key in text and says in text, text
    if info:  # a problem in the camera_info file names that file
        assert "front.yaml" in text
