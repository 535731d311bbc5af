"""The shipped example tracks: reproducible, pure-coloured and drivable.

``example_tracks/make_example_tracks.py`` writes three tinycarlo 1.1 track
folders. These tests rebuild them into a temporary folder and compare with the
committed files, then check the promises the simulator's own tests rely on:
binary colours, spawns on the trajectory, markings on the right side of the
driving direction, and a car footprint that follows the trajectory without
touching an obstacle colour.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from tinyrace.examples import TRACKS_DIR

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = TRACKS_DIR
SCRIPT = EXAMPLES / "make_example_tracks.py"
TRACKS = ["segmented", "formula_student", "carolo_cup"]

WHEELBASE_PX = 150  # rear axle to front axle
TRACK_WIDTH_PX = 100
MIN_MARGIN_PX = 40  # promised clearance on each side of the footprint
MIN_RADIUS_PX = 380  # gentlest allowed trajectory turn radius; 33 deg lock gives ~230
MAX_IMAGE_HW = (2000, 2500)  # [px] (height, width)
MAX_PNG_BYTES = 200_000

BLACK, WHITE, BLUE = (0, 0, 0), (255, 255, 255), (255, 0, 0)
GREEN, RED, YELLOW, MAGENTA = (0, 255, 0), (0, 0, 255), (0, 255, 255), (255, 0, 255)

# Every colour each image may hold (BGR), and which ones must lie left or right
# of the driving direction as seen from the trajectory.
COLORS = {
    "segmented": {BLACK, WHITE, YELLOW, RED, MAGENTA, GREEN},
    "formula_student": {BLACK, BLUE, YELLOW, WHITE},
    "carolo_cup": {BLACK, WHITE, RED, GREEN},
}
LEFT_OF_TRAJECTORY = {
    "segmented": [YELLOW],  # dashed centre line: the trajectory is in the right lane
    "formula_student": [BLUE],
    "carolo_cup": [RED],  # obstacle boxes stand in the left lane
}
RIGHT_OF_TRAJECTORY = {"segmented": [], "formula_student": [YELLOW], "carolo_cup": []}

KNOWN_KEYS = {
    "": {"sim", "reward_design", "car", "cameras", "tracks"},
    "sim": {"fps", "render_realtime", "step_limit", "overview_downscale"},
    "reward_design": {"color_obstacles", "cross_track_error"},
    "color_obstacles": {"color", "reward"},
    "cross_track_error": {"use_cte", "trajectory_color"},
    "car": {"wheelbase", "track_width", "velocity", "max_steering_change"},
    "cameras": {"id", "resolution", "roi", "position"},
    "tracks": {"image", "spawns"},
}


# --------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------


def load_track(folder: Path) -> tuple[dict, np.ndarray]:
    """track.yaml as a dict and its (only) image as a BGR array."""
    config = yaml.safe_load((folder / "track.yaml").read_text())
    image = cv2.imread(str(folder / config["tracks"][0]["image"]), cv2.IMREAD_UNCHANGED)
    assert image is not None and image.ndim == 3 and image.shape[2] == 3
    return config, image


def color_mask(image: np.ndarray, colors: list) -> np.ndarray:
    """uint8 mask (1 = pixel has one of ``colors``)."""
    mask = np.zeros(image.shape[:2], bool)
    for color in colors:
        mask |= np.all(image == np.array(color, np.uint8), axis=2)
    return mask.astype(np.uint8)


def trajectory_mask(config: dict, image: np.ndarray) -> np.ndarray:
    """uint8 mask of the trajectory colour."""
    return color_mask(image, [config["reward_design"]["cross_track_error"]["trajectory_color"]])


def obstacle_colors(config: dict) -> list:
    """The BGR colours listed under color_obstacles."""
    return [o["color"] for o in config["reward_design"]["color_obstacles"]]


def ordered_trajectory(
    config: dict, image: np.ndarray, step_px: float = 2.0
) -> tuple[np.ndarray, np.ndarray]:
    """The trajectory as evenly spaced points (N, 2) in driving order, and unit directions.

    The outer contour of the (thin, closed) trajectory line gives the order;
    the first spawn's heading picks which way round is forward. (A first spawn
    facing backwards would then put the markings on the wrong side, which
    ``test_markings_lie_on_their_side_of_the_driving_direction`` catches.)
    """
    contours, _ = cv2.findContours(
        trajectory_mask(config, image), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE
    )
    contour = max(contours, key=len)[:, 0, :].astype(float)
    closed = np.concatenate([contour, contour[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    targets = np.arange(0.0, s[-1], step_px)
    points = np.stack([np.interp(targets, s, closed[:, i]) for i in (0, 1)], axis=1)
    k = 10  # central difference over +-20 px smooths out the pixel staircase
    directions = np.roll(points, -k, axis=0) - np.roll(points, k, axis=0)
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    x, y, heading = config["tracks"][0]["spawns"][0]
    nearest = np.argmin(np.hypot(points[:, 0] - x, points[:, 1] - y))
    if directions[nearest] @ (math.cos(heading), math.sin(heading)) < 0:
        points, directions = points[::-1].copy(), -directions[::-1]
    return points, directions


def footprint(point: np.ndarray, direction: np.ndarray, margin: float) -> np.ndarray:
    """Corners of the car rectangle: rear axle at ``point``, widened by ``margin`` each side."""
    right = np.array([-direction[1], direction[0]])
    half = TRACK_WIDTH_PX / 2 + margin
    front = point + WHEELBASE_PX * direction
    return np.array(
        [point - half * right, front - half * right, front + half * right, point + half * right]
    )


# --------------------------------------------------------------------------
# Tests
# --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The example tracks, freshly written by the script into a temporary folder."""
    out = tmp_path_factory.mktemp("example_tracks")
    subprocess.run([sys.executable, str(SCRIPT), str(out)], check=True, timeout=120)
    return out


@pytest.mark.parametrize("name", TRACKS)
def test_script_reproduces_committed_files(name: str, regenerated: Path) -> None:
    committed_config, committed_image = load_track(EXAMPLES / name)
    fresh_config, fresh_image = load_track(regenerated / name)
    assert fresh_config == committed_config
    assert (regenerated / name / "track.yaml").read_text() == (
        EXAMPLES / name / "track.yaml"
    ).read_text()
    assert np.array_equal(fresh_image, committed_image)
    assert sorted(p.name for p in (regenerated / name).iterdir()) == sorted(
        p.name for p in (EXAMPLES / name).iterdir()
    )


@pytest.mark.parametrize("name", TRACKS)
def test_track_yaml_uses_only_tinycarlo_keys_and_the_agreed_car(name: str) -> None:
    config, _ = load_track(EXAMPLES / name)
    assert set(config) == KNOWN_KEYS[""]
    assert set(config["sim"]) <= KNOWN_KEYS["sim"]
    assert set(config["reward_design"]) <= KNOWN_KEYS["reward_design"]
    for obstacle in config["reward_design"]["color_obstacles"]:
        assert set(obstacle) == KNOWN_KEYS["color_obstacles"]
        assert obstacle["reward"] == "done" or isinstance(obstacle["reward"], int)
    assert set(config["reward_design"]["cross_track_error"]) == KNOWN_KEYS["cross_track_error"]
    assert config["car"]["wheelbase"] == WHEELBASE_PX
    assert config["car"]["track_width"] == TRACK_WIDTH_PX
    assert 300 <= config["car"]["velocity"] <= 500
    assert config["car"]["max_steering_change"] > 0
    assert config["sim"]["fps"] == 30 and config["sim"]["render_realtime"] is True
    assert config["sim"]["overview_downscale"] >= 1
    assert isinstance(config["cameras"], list) and len(config["cameras"]) == 1
    assert set(config["cameras"][0]) == KNOWN_KEYS["cameras"]
    assert isinstance(config["tracks"], list) and len(config["tracks"]) == 1
    assert set(config["tracks"][0]) == KNOWN_KEYS["tracks"]
    assert len(config["tracks"][0]["spawns"]) == 2


@pytest.mark.parametrize("name", TRACKS)
def test_image_is_small_and_pure_coloured(name: str) -> None:
    config, image = load_track(EXAMPLES / name)
    assert image.shape[0] <= MAX_IMAGE_HW[0] and image.shape[1] <= MAX_IMAGE_HW[1]
    assert (EXAMPLES / name / config["tracks"][0]["image"]).stat().st_size < MAX_PNG_BYTES
    assert np.isin(image, (0, 255)).all()
    packed = np.unique(image.reshape(-1, 3).astype(np.int32) @ (1 << 16, 1 << 8, 1))
    present = {(int(p >> 16), int(p >> 8 & 255), int(p & 255)) for p in packed}
    assert present == COLORS[name]
    trajectory = tuple(config["reward_design"]["cross_track_error"]["trajectory_color"])
    declared = {tuple(c) for c in obstacle_colors(config)} | {trajectory}
    assert declared <= present
    assert trajectory not in {tuple(c) for c in obstacle_colors(config)}


@pytest.mark.parametrize("name", TRACKS)
def test_trajectory_colour_is_one_thin_closed_line(name: str) -> None:
    config, image = load_track(EXAMPLES / name)
    mask = trajectory_mask(config, image)
    count, _ = cv2.connectedComponents(mask, connectivity=8)
    assert count == 2  # background + one line: the colour appears nowhere else
    _, hierarchy = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    outer = [i for i, h in enumerate(hierarchy[0]) if h[3] < 0]
    holes = [i for i, h in enumerate(hierarchy[0]) if h[3] >= 0]
    assert len(outer) == 1 and len(holes) == 1  # a ring: the line closes on itself
    assert not cv2.erode(mask, np.ones((4, 4), np.uint8)).any()  # thinner than 4 px


@pytest.mark.parametrize("name", TRACKS)
def test_spawns_lie_on_the_trajectory_and_face_along_it(name: str) -> None:
    config, image = load_track(EXAMPLES / name)
    ys, xs = np.nonzero(trajectory_mask(config, image))
    points, directions = ordered_trajectory(config, image)
    for x, y, heading in config["tracks"][0]["spawns"]:
        assert np.hypot(xs - x, ys - y).min() <= 2
        along = directions[np.argmin(np.hypot(points[:, 0] - x, points[:, 1] - y))]
        error = math.remainder(heading - math.atan2(along[1], along[0]), math.tau)
        assert abs(error) < math.radians(5), f"spawn {(x, y, heading)} is off by {error} rad"


@pytest.mark.parametrize("name", TRACKS)
def test_markings_lie_on_their_side_of_the_driving_direction(name: str) -> None:
    config, image = load_track(EXAMPLES / name)
    points, directions = ordered_trajectory(config, image)
    sides = [(color, -1) for color in LEFT_OF_TRAJECTORY[name]]
    sides += [(color, +1) for color in RIGHT_OF_TRAJECTORY[name]]
    for color, side in sides:
        ys, xs = np.nonzero(color_mask(image, [color]))
        pixels = np.stack([xs, ys], axis=1)[::7].astype(float)
        assert len(pixels) > 0
        for chunk in np.array_split(pixels, max(1, len(pixels) // 500)):
            gaps = chunk[:, None, :] - points[None, :, :]
            nearest = np.argmin(np.einsum("ijk,ijk->ij", gaps, gaps), axis=1)
            d, v = directions[nearest], chunk - points[nearest]
            cross = d[:, 0] * v[:, 1] - d[:, 1] * v[:, 0]  # > 0: right of the driving direction
            assert (np.sign(cross) == side).all(), f"{color} on the wrong side"


@pytest.mark.parametrize("margin", [0, MIN_MARGIN_PX])
@pytest.mark.parametrize("name", TRACKS)
def test_footprint_following_the_trajectory_touches_no_obstacle(name: str, margin: int) -> None:
    config, image = load_track(EXAMPLES / name)
    obstacles = color_mask(image, obstacle_colors(config))
    points, directions = ordered_trajectory(config, image)
    for point, direction in zip(points, directions, strict=True):
        corners = footprint(point, direction, margin)
        x0, y0 = np.floor(corners.min(axis=0)).astype(int) - 1
        x1, y1 = np.ceil(corners.max(axis=0)).astype(int) + 2
        assert x0 >= 0 and y0 >= 0 and x1 <= image.shape[1] and y1 <= image.shape[0]
        car = np.zeros((y1 - y0, x1 - x0), np.uint8)
        cv2.fillConvexPoly(car, np.round(corners - (x0, y0)).astype(np.int32), 1, cv2.LINE_8)
        hits = car & obstacles[y0:y1, x0:x1]
        assert not hits.any(), f"footprint at {point.round(1)} touches an obstacle"


@pytest.mark.parametrize("name", TRACKS)
def test_trajectory_turns_gently_enough_for_the_car(name: str) -> None:
    config, image = load_track(EXAMPLES / name)
    points, _ = ordered_trajectory(config, image)
    k = 75  # samples of 2 px: a circle through points 150 px apart
    a, b, c = np.roll(points, k, axis=0), points, np.roll(points, -k, axis=0)
    ab, bc, ca = (np.linalg.norm(p - q, axis=1) for p, q in ((a, b), (b, c), (c, a)))
    cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    radius = ab * bc * ca / np.maximum(2 * cross, 1e-9)
    assert radius.min() >= MIN_RADIUS_PX
    # A kinematic bicycle holds that radius with a steering angle well below full lock (33 deg).
    assert math.degrees(math.atan(WHEELBASE_PX / radius.min())) < 33
