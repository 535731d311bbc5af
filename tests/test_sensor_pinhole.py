"""Pinhole camera core: known ground points land within 1 px of the pinhole formula."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from tinyrace.sensors.machinery.pinhole import Pinhole, car_to_world, render, world_to_car

PX_PER_UNIT = 20.0  # texture resolution of the test ground
SIDE = 60.0  # [u] the test ground spans [-30, 30] on both axes, y up
WORLD_TO_GROUND = np.array(
    [[PX_PER_UNIT, 0, SIDE / 2 * PX_PER_UNIT], [0, -PX_PER_UNIT, SIDE / 2 * PX_PER_UNIT]]
)
CORNERS = np.array([[6.0, -1.5], [6.0, 1.5], [10.0, 1.5], [10.0, -1.5], [4.0, 0.0]])  # ahead, right


def _ground_with_dots(world_points: np.ndarray, to_ground: np.ndarray) -> np.ndarray:
    """A black RGBx ground with a white disc of radius 0.3 u on each world point (sub-pixel
    exact centres); ``to_ground`` maps track units to its pixels."""
    size = int(SIDE * PX_PER_UNIT)
    ground = np.zeros((size, size, 4), np.uint8)
    shift = 4  # cv2 fixed-point bits: centres to 1/16 px
    for x, y in world_points:
        px, py = to_ground @ (x, y, 1)
        centre = (round(px * 2**shift), round(py * 2**shift))
        radius = round(0.3 * PX_PER_UNIT * 2**shift)
        cv2.circle(ground, centre, radius, (255, 255, 255, 255), -1, cv2.LINE_AA, shift)
    return ground


def _blob_centres(image: np.ndarray) -> np.ndarray:
    """Intensity-weighted centroids (u, v) of the bright blobs of an image."""
    grey = image[..., 0].astype(np.float64)
    count, labels = cv2.connectedComponents((grey > 0).astype(np.uint8))
    v, u = np.mgrid[: grey.shape[0], : grey.shape[1]]
    centres = []
    for label in range(1, count):
        w = np.where(labels == label, grey, 0)
        centres.append(((u * w).sum() / w.sum(), (v * w).sum() / w.sum()))
    return np.array(centres)


def _car_to_world(pose_front, heading, y_down, points):
    inverse = np.linalg.inv(world_to_car(pose_front, heading, y_down))
    homogeneous = np.column_stack([points, np.ones(len(points))])
    return (homogeneous @ inverse.T)[:, :2]


def _pitch_only_formula(camera: Pinhole, ahead_right: np.ndarray) -> np.ndarray:
    """The textbook pinhole: a camera at height h pitched down by p sees ground point
    (a, b) (relative to it) at u = cx + f b / Z, v = cy + f (h cos p - a sin p) / Z,
    Z = a cos p + h sin p, with f = (W / 2) / tan(fov / 2)."""
    width, height = camera.size
    f = width / 2 / math.tan(camera.hfov / 2)
    a = ahead_right[:, 0] - camera.position[0]
    b = ahead_right[:, 1] - camera.position[1]
    h, p = camera.position[2], camera.pitch
    z = a * math.cos(p) + h * math.sin(p)
    return np.stack(
        [
            (width - 1) / 2 + f * b / z,
            (height - 1) / 2 + f * (h * math.cos(p) - a * math.sin(p)) / z,
        ],
        axis=1,
    )


@pytest.mark.parametrize("y_down", [False, True])
def test_marking_corners_land_on_the_pinhole_formula(y_down):
    camera = Pinhole((160, 120), math.radians(90), (-0.5, 0.3, 2.5), pitch=math.radians(20))
    front, heading = (3.0, -2.0), 0.4
    to_ground = WORLD_TO_GROUND * [[1, 1, 1], [1, -1, 1]] if y_down else WORLD_TO_GROUND
    world = _car_to_world(front, heading, y_down, CORNERS)
    ground = _ground_with_dots(world, to_ground)
    image = render(camera, ground, to_ground, car_to_world(front, heading, y_down), (0,) * 4)
    errors = _errors(_blob_centres(image), _pitch_only_formula(camera, CORNERS))
    assert errors.max() <= 1.0


def test_turned_camera_finds_points_where_project_puts_them():
    camera = Pinhole(
        (160, 120),
        math.radians(100),
        (0.2, -0.4, 2.0),
        yaw=math.radians(-15),
        pitch=math.radians(25),
        roll=math.radians(4),
    )
    front, heading = (-5.0, 4.0), 2.1
    world = _car_to_world(front, heading, False, CORNERS)
    ground = _ground_with_dots(world, WORLD_TO_GROUND)
    image = render(camera, ground, WORLD_TO_GROUND, car_to_world(front, heading, False), (0,) * 4)
    expected = camera.project(np.column_stack([CORNERS, np.zeros(len(CORNERS))]))
    assert _errors(_blob_centres(image), expected).max() <= 1.0


def _errors(found: np.ndarray, expected: np.ndarray) -> np.ndarray:
    """Distance [px] from each expected point to the blob found nearest to it (one blob each)."""
    assert len(found) == len(expected)
    return np.array([np.min(np.hypot(*(found - point).T)) for point in expected])


def test_project_matches_the_textbook_formula():
    camera = Pinhole((320, 240), math.radians(70), (1.0, 0.5, 1.2), pitch=math.radians(30))
    points = np.column_stack([CORNERS, np.zeros(len(CORNERS))])
    np.testing.assert_allclose(camera.project(points), _pitch_only_formula(camera, CORNERS))


def test_sky_above_the_horizon_and_beyond_max_range():
    level = Pinhole((80, 60), math.radians(90), (0, 0, 1.0))
    rows = level.sky.all(axis=1)
    assert rows[:30].all() and not level.sky[30:].any()  # horizon at v = 29.5
    near = Pinhole((80, 60), math.radians(90), (0, 0, 1.0), pitch=math.radians(45), max_range=3.0)
    # the centre ray meets the ground 1 u ahead; the ground 3 u away is seen at row 9.5
    assert not near.sky[30, 40]
    assert near.sky[0, 40]
    v_far = (60 - 1) / 2 - 40 * math.tan(math.radians(45) - math.atan(1 / 3.0))  # 9.5
    column = near.sky[:, 40]
    assert column[: math.floor(v_far)].all() and not column[math.ceil(v_far) :].any()


def test_sky_colour_fills_the_sky():
    camera = Pinhole((40, 30), math.radians(90), (0, 0, 1.0))
    ground = np.full((100, 100, 3), 50, np.uint8)
    image = render(
        camera,
        ground,
        np.array([[1.0, 0, 50], [0, 1.0, 50]]),
        car_to_world((0, 0), 0, True),
        (1, 2, 3),
    )
    assert (image[:15] == (1, 2, 3)).all() and (image[-1] == 50).all()


def test_sky_of_a_rolled_camera_follows_its_mask():
    camera = Pinhole((40, 30), math.radians(90), (0, 0, 1.0), roll=math.radians(30))
    assert camera.sky.any() and not camera.sky.all(axis=1).all()
    ground = np.full((100, 100, 3), 50, np.uint8)
    to_ground = np.array([[1.0, 0, 50], [0, 1.0, 50]])
    image = render(camera, ground, to_ground, car_to_world((0, 0), 0, True), (1, 2, 3))
    np.testing.assert_array_equal(np.all(image == (1, 2, 3), axis=-1), camera.sky)
