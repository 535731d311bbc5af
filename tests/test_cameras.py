"""Cameras on image tracks see what tinycarlo's camera sees from the same pose.

``tinycarlo_camera`` below is a small reference implementation of tinycarlo
1.1's documented camera: rotate the whole track image about the car so that
its heading points up, crop the roi window ahead of the front axle (shifted
by ``position``: +y ahead, +x right), resize it to the resolution with
cv2.resize. Coloured squares are placed at known offsets from the car; their
centroids and colours in tinyrace's observation must match the reference's.
"""

from __future__ import annotations

import math
import tracemalloc

import cv2
import numpy as np
import pytest
from synthetic import (
    BGR,
    blank,
    car_point,
    centroid,
    color_mask,
    make_env,
    square,
    straight,
    write_track,
)

WHEELBASE = 100  # [px]
MARK = 16  # [px] side of a marking square


def tinycarlo_camera(
    image_bgr: np.ndarray,
    pose: tuple[float, float, float],
    wheelbase: float,
    roi: tuple[int, int],
    resolution: tuple[int, int],
    position: tuple[int, int] = (0, 0),
) -> np.ndarray:
    """tinycarlo 1.1's camera image (converted to RGB) for a car at ``pose`` (rear axle)."""
    x, y, heading = pose
    roi_y, roi_x = roi
    # a canvas large enough to hold the window wherever it is (tinycarlo uses the image size)
    side = 2 * int(wheelbase + roi_y + roi_x + abs(position[0]) + abs(position[1]) + 4)
    c = side // 2
    to_centre = np.array([[1, 0, c - x], [0, 1, c - y], [0, 0, 1]], np.float64)
    rotate = np.vstack([cv2.getRotationMatrix2D((c, c), math.degrees(heading) + 90, 1), [0, 0, 1]])
    upright = cv2.warpAffine(image_bgr, (rotate @ to_centre)[:2], (side, side))
    left = c - roi_x // 2 + position[1]
    bottom = c - int(wheelbase) - position[0]
    crop = upright[bottom - roi_y : bottom, left : left + roi_x]
    resized = cv2.resize(crop, (resolution[1], resolution[0]))
    return cv2.cvtColor(resized, cv2.COLOR_BGR2RGB)


def virtual_pose(pose, wheelbase, yaw_deg, position=(0, 0)):
    """A tinycarlo car whose camera sees what a camera turned by ``yaw_deg`` sees.

    Its front axle is the camera's mount point and its heading the camera's direction.
    """
    mx, my = car_point(pose, wheelbase + position[0], position[1])
    heading = pose[2] + math.radians(yaw_deg)
    return (mx - wheelbase * math.cos(heading), my - wheelbase * math.sin(heading), heading)


def marked_track(tmp_path, pose, marks, cameras, size=600, shift=0):
    """A black ``size`` image with squares at (forward of the front axle, right) offsets."""
    image = blank(size, size)
    spawn = (pose[0] + shift, pose[1] + shift, pose[2])
    for name, (forward, right) in marks.items():
        square(image, car_point(spawn, WHEELBASE + forward, right), MARK, BGR[name])
    config = {
        "car": {"wheelbase": WHEELBASE},
        "cameras": cameras,
        "tracks": [{"image": "track.png", "spawns": [list(spawn)]}],
    }
    return write_track(tmp_path / f"marked{size}", image, config), image


def assert_same_markings(got: np.ndarray, expected: np.ndarray, names, tolerance=1.0):
    for name in names:
        expected_mask = color_mask(expected, BGR[name])
        got_mask = color_mask(got, BGR[name])
        assert expected_mask.sum() >= 4, f"{name} should be in view of the reference"
        assert got_mask.sum() >= 4, f"{name} is missing from the camera image"
        gx, gy = centroid(got_mask)
        ex, ey = centroid(expected_mask)
        assert abs(gx - ex) <= tolerance and abs(gy - ey) <= tolerance, (name, (gx, gy), (ex, ey))
        # same colour: the marking's middle pixel is the pure colour, in RGB order
        cx, cy = round(gx), round(gy)
        assert tuple(got[cy, cx]) == BGR[name][::-1], (name, got[cy, cx])


FRONT_MARKS = {"red": (150, 0), "green": (60, -50), "blue": (200, 60), "yellow": (120, 40)}


@pytest.mark.parametrize("heading", [0.3, -2.0, math.pi / 2])
@pytest.mark.parametrize("position", [(0, 0), (20, 10), (-30, -16)])
def test_front_camera_matches_tinycarlo(tmp_path, heading, position):
    pose = (300.0, 300.0, heading)
    camera = {"id": "front", "resolution": [60, 80], "roi": [240, 200], "position": list(position)}
    folder, image = marked_track(tmp_path, pose, FRONT_MARKS, [camera])
    env = make_env(folder)
    observation, info = env.reset(seed=0)
    assert info["pose"] == pytest.approx(pose)  # the reset observation is taken at the spawn
    expected = tinycarlo_camera(image, pose, WHEELBASE, (240, 200), (60, 80), position)
    in_view = [n for n in FRONT_MARKS if color_mask(expected, BGR[n]).sum() >= 4]
    assert len(in_view) >= 3  # the scene really tests something
    assert_same_markings(observation["front"], expected, in_view)
    # and after driving with the wheels turned, from wherever the car is then
    for _ in range(3):
        observation, _, _, _, info = env.step(np.array([0.4], np.float32))
    expected = tinycarlo_camera(image, info["pose"], WHEELBASE, (240, 200), (60, 80), position)
    in_view = [n for n in FRONT_MARKS if color_mask(expected, BGR[n]).sum() >= 4]
    assert_same_markings(observation["front"], expected, in_view)


def test_position_shifts_the_window_ahead_and_right(tmp_path):
    """position [y, x]: +y moves the window ahead, +x to the car's right (as tinycarlo)."""
    pose = (300.0, 300.0, 0.0)
    cameras = [
        {"id": "base", "resolution": [120, 160], "roi": [120, 160]},
        {"id": "shifted", "resolution": [120, 160], "roi": [120, 160], "position": [30, 20]},
    ]
    folder, _ = marked_track(tmp_path, pose, {"red": (60, 0)}, cameras)
    observation, _ = make_env(folder).reset(seed=0)
    bx, by = centroid(color_mask(observation["base"], BGR["red"]))
    sx, sy = centroid(color_mask(observation["shifted"], BGR["red"]))
    # the window moved 30 px ahead and 20 px right: the marking moves down 30 and left 20
    assert sy - by == pytest.approx(30, abs=0.6)
    assert sx - bx == pytest.approx(-20, abs=0.6)


SIDE_MARKS = {"red": (-100, 0), "blue": (40, -95), "yellow": (40, 95), "magenta": (90, 0)}
SEEN_BY = {0: "magenta", 180: "red", -90: "blue", 90: "yellow"}


def test_turned_cameras_see_behind_left_and_right(tmp_path):
    pose = (300.0, 300.0, 0.3)
    cameras = [
        {"id": f"yaw{yaw}", "resolution": [60, 80], "roi": [120, 160], "yaw": yaw}
        for yaw in SEEN_BY
    ]
    folder, image = marked_track(tmp_path, pose, SIDE_MARKS, cameras)
    observation, _ = make_env(folder).reset(seed=0)
    assert set(observation) == {c["id"] for c in cameras}
    for yaw, name in SEEN_BY.items():
        got = observation[f"yaw{yaw}"]
        for other in SIDE_MARKS:  # each camera sees its own marking and no other
            assert (color_mask(got, BGR[other]).sum() > 0) == (other == name), (yaw, other)
        turned = virtual_pose(pose, WHEELBASE, yaw)
        expected = tinycarlo_camera(image, turned, WHEELBASE, (120, 160), (60, 80))
        assert_same_markings(got, expected, [name])
    # the rear camera sees the marking as far up its window as it lies behind the front axle
    # (100 px; output row i shows the distance (60 - 0.5 - i) * 2 px)
    _, y = centroid(color_mask(observation["yaw180"], BGR["red"]))
    assert (60 - 0.5 - y) * 2 == pytest.approx(100, abs=2)


def test_observation_is_a_dict_of_rgb_uint8_images(tmp_path):
    cameras = [
        {"id": "a", "resolution": [30, 40], "roi": [60, 80]},
        {"id": "b", "resolution": [48, 48], "roi": [100, 100], "yaw": 45},
        {"id": "wide", "resolution": [20, 90], "roi": [40, 180], "position": [10, -5]},
    ]
    image = blank()
    image[:, 350:] = BGR["red"]  # everything ahead of the front axle is red
    tracks = [{"image": "track.png", "spawns": [[150, 300, 0]]}]
    folder = write_track(tmp_path, image, {"cameras": cameras, "tracks": tracks})
    env = make_env(folder)
    observation, _ = env.reset(seed=0)
    assert list(observation) == ["a", "b", "wide"]
    for camera in cameras:
        frame = observation[camera["id"]]
        assert frame.dtype == np.uint8
        assert frame.shape == (*camera["resolution"], 3)
    assert env.observation_space.contains(observation)
    env.step(straight())
    for _ in range(5):
        observation, *_ = env.step(straight())
    # the front camera now looks at the red half: red in RGB order is (255, 0, 0)
    assert tuple(observation["a"][5, 20]) == (255, 0, 0)


def test_camera_cost_does_not_depend_on_the_image_size(tmp_path, monkeypatch):
    """The same scene on a 600 and a 3000 px image: identical images, camera-sized warps."""
    pose = (200.0, 320.0, 0.3)
    camera = {"id": "front", "resolution": [60, 80], "roi": [240, 200], "position": [0, 0]}
    small, _ = marked_track(tmp_path, pose, FRONT_MARKS, [camera], size=600)
    large, _ = marked_track(tmp_path, pose, FRONT_MARKS, [camera], size=3000, shift=1200)
    small_env, large_env = make_env(small), make_env(large)
    small_obs, _ = small_env.reset(seed=0)
    large_obs, _ = large_env.reset(seed=0)
    assert color_mask(small_obs["front"], BGR["red"]).sum() > 0
    np.testing.assert_array_equal(small_obs["front"], large_obs["front"])

    warps = []
    real_warp = cv2.warpAffine

    def spy(src, matrix, dsize, *args, **kwargs):
        warps.append(tuple(dsize))
        return real_warp(src, matrix, dsize, *args, **kwargs)

    monkeypatch.setattr(cv2, "warpAffine", spy)
    large_env.step(straight())
    tracemalloc.start()
    for _ in range(5):
        large_env.step(straight())
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert warps and set(warps) == {(80, 60)}  # only the camera's own pixels are warped
    image_bytes = 3000 * 3000 * 3
    assert peak < image_bytes / 50  # no image-sized array is made per step
