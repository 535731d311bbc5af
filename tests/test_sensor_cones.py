"""Cone detection core: range, field of view, frame, order, noise and picture blobs."""

from __future__ import annotations

import math

import cv2
import numpy as np

from tinyrace.sensors.cones import ConeNoise, cones_from_picture, detect, to_car_frame

CONES = np.array(
    [
        [10.0, 2.0, 1],  # ahead, left: blue
        [10.0, -2.0, 2],  # ahead, right: yellow
        [4.0, 1.0, 3],  # nearest: orange
        [-5.0, 0.0, 1],  # behind
        [50.0, 0.0, 2],  # too far
    ]
)


def test_visible_cones_in_the_car_frame_nearest_first():
    rows, count = detect(CONES, (0, 0, 0), False, 20.0, math.radians(120), 8, ConeNoise(), None)
    assert count == 3 and rows.dtype == np.float32 and rows.shape == (8, 3)
    np.testing.assert_allclose(rows[:3], [[4, 1, 3], [10, 2, 1], [10, -2, 2]], atol=1e-6)
    assert not rows[3:].any()


def test_turned_car_and_y_down_frames():
    pose = (1.0, 1.0, math.pi / 2)  # y-up: facing +y
    np.testing.assert_allclose(
        to_car_frame(np.array([[1.0, 3.0], [0.0, 1.0]]), pose, False), [[2, 0], [0, 1]], atol=1e-12
    )
    # y-down: heading pi/2 faces +y (down the picture); the car's left is +x
    np.testing.assert_allclose(
        to_car_frame(np.array([[2.0, 1.0]]), pose, True), [[0, 1]], atol=1e-12
    )


def test_capacity_keeps_the_nearest():
    rows, count = detect(CONES, (0, 0, 0), False, 20.0, math.radians(120), 2, ConeNoise(), None)
    assert count == 2
    np.testing.assert_allclose(rows[:, 2], [3, 1])


def test_noise_misses_and_false_positives_follow_the_seed():
    many = np.column_stack([np.full(400, 5.0), np.linspace(-2, 2, 400), np.ones(400)])
    noise = ConeNoise(position_std=0.1, miss_probability=0.25, false_positives=3.0)
    args = ((0, 0, 0), False, 20.0, math.pi, 500, noise)
    a = detect(many, *args, np.random.default_rng(7))
    b = detect(many, *args, np.random.default_rng(7))
    np.testing.assert_array_equal(a[0], b[0])
    counts = [detect(many, *args, np.random.default_rng(seed))[1] for seed in range(40)]
    assert abs(np.mean(counts) - (300 + 3)) < 6  # 75 % of 400 kept, plus 3 made up
    rows = a[0][: a[1]]
    true_x = rows[np.abs(rows[:, 0] - 5.0) < 0.5, 0]
    assert abs(np.std(true_x) - 0.1) < 0.02


def test_cones_from_picture_finds_each_blob_centre():
    picture = np.zeros((100, 120, 4), np.uint8)
    picture[..., 3] = 255
    cv2.circle(picture, (30, 40), 5, (0, 0, 255, 255), -1)  # RGBx blue
    cv2.circle(picture, (80, 20), 4, (255, 255, 0, 255), -1)  # yellow
    cv2.circle(picture, (90, 70), 4, (255, 255, 0, 255), -1)
    found = cones_from_picture(picture, {1: (0, 0, 255), 2: (255, 255, 0)})
    found = found[np.lexsort((found[:, 0], found[:, 2]))]
    np.testing.assert_allclose(found, [[30, 40, 1], [80, 20, 2], [90, 70, 2]], atol=1e-6)
