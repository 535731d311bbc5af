"""Colour obstacles under the footprint, and the cross-track error to a trajectory.

The footprint is track_width wide, from the rear axle to the front axle; a
pixel counts when its centre (integer coordinates) lies inside it or on its
edge. The cross-track error is the distance from the middle of the rear axle
to the nearest trajectory pixel.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples
from synthetic import BGR, blank, color_mask, make_env, straight, write_track

from tinyrace.config import Color
from tinyrace.tracks.image import (
    ImageTrack,
    ObstaclePixels,
    _box_inside,
    _inner_edges,
    _inside_span,
    _obstacle_cells,
    _row_spans,
    _span_edges,
)
from tinyrace.tracks.nearest import NearestPoint

WHEELBASE, TRACK_WIDTH = 100, 60  # [px]
RED_BGR = [0, 0, 255]


def footprint_margin(points: np.ndarray, pose, wheelbase=WHEELBASE, width=TRACK_WIDTH):
    """Signed distance of each (x, y) inside the footprint at ``pose`` (< 0: outside)."""
    x, y, heading = pose
    forward = np.array([math.cos(heading), math.sin(heading)])
    right = np.array([-forward[1], forward[0]])
    offsets = points - (x, y)
    along, side = offsets @ forward, offsets @ right
    return np.minimum.reduce([along, wheelbase - along, width / 2 - side, width / 2 + side])


def obstacle_env(tmp_path, image, spawn, reward=-7, velocity=310.0, **extra):
    config = {
        "car": {"wheelbase": WHEELBASE, "track_width": TRACK_WIDTH, "velocity": velocity},
        "reward_design": {"color_obstacles": [{"color": RED_BGR, "reward": reward}], **extra},
        "tracks": [{"image": "track.png", "spawns": [list(spawn)]}],
    }
    return make_env(write_track(tmp_path, image, config))


def drive_straight(env, steps):
    """(info, reward, terminated) of each step."""
    env.reset(seed=0)
    out = []
    for _ in range(steps):
        _, reward, terminated, _, info = env.step(straight())
        out.append((info, reward, terminated))
        if terminated:
            break
    return out


# -- colour obstacles -----------------------------------------------------------------------


@pytest.mark.parametrize("heading", [0.0, 0.7, -2.0, math.pi / 2])
@pytest.mark.parametrize("lateral", [0.0, 22.0, -27.0])
def test_obstacle_fires_when_the_footprint_front_reaches_it(tmp_path, heading, lateral):
    velocity, fps = 310.0, 30  # 10.33 px per step
    spawn = (300.0, 300.0, heading)
    ahead = 130.0  # [px] from the front axle to the block
    bx = spawn[0] + (WHEELBASE + ahead) * math.cos(heading) - lateral * math.sin(heading)
    by = spawn[1] + (WHEELBASE + ahead) * math.sin(heading) + lateral * math.cos(heading)
    image = blank()
    x0, y0 = round(bx) - 1, round(by) - 1
    image[y0 : y0 + 3, x0 : x0 + 3] = BGR["red"]  # a 3 x 3 block
    ys, xs = np.mgrid[y0 : y0 + 3, x0 : x0 + 3]
    block = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(float)

    def covered(k):  # does the footprint after k steps cover a block pixel's centre?
        d = k * velocity / fps
        pose = (spawn[0] + d * math.cos(heading), spawn[1] + d * math.sin(heading), heading)
        margins = footprint_margin(block, pose)
        assert np.all(np.abs(margins) > 1e-3), "choose a scene without boundary cases"
        return bool(np.any(margins > 0))

    first = next(k for k in range(1, 60) if covered(k))
    steps = drive_straight(obstacle_env(tmp_path, image, spawn, velocity=velocity), first + 2)
    for k, (info, reward, _) in enumerate(steps, start=1):
        assert bool(info["obstacles_hit"]) == covered(k), k
        assert reward == (-7.0 if covered(k) else 0.0)
    info, reward, terminated = steps[first - 1]
    assert info["obstacles_hit"] == ["#ff0000"]  # red, named in RGB
    assert info["reward_terms"] == {"obstacles": -7.0}
    assert not terminated


def test_first_hit_step_from_speed_and_geometry(tmp_path):
    """Heading 0: the front edge is at x = spawn + wheelbase + k * v / fps after k steps."""
    velocity, fps, spawn_x, block_x = 310.0, 30, 100.0, 333
    image = blank()
    image[295:306, block_x : block_x + 5] = BGR["red"]
    steps = drive_straight(obstacle_env(tmp_path, image, (spawn_x, 300.0, 0.0)), 30)
    hits = [k for k, (info, _, _) in enumerate(steps, start=1) if info["obstacles_hit"]]
    first = math.ceil((block_x - spawn_x - WHEELBASE) / (velocity / fps))  # 12.9 -> 13
    # it stays touched until the rear axle passes the block's last column (337)
    last = math.floor((block_x + 4 - spawn_x) / (velocity / fps))
    assert hits == list(range(first, last + 1))


def test_done_obstacle_terminates(tmp_path):
    image = blank()
    image[280:320, 400:420] = BGR["red"]
    steps = drive_straight(obstacle_env(tmp_path, image, (100.0, 300.0, 0.0), reward="done"), 60)
    info, reward, terminated = steps[-1]
    first = math.ceil((400 - 100 - WHEELBASE) / (310 / 30))
    assert len(steps) == first and terminated
    assert reward == 0.0  # as tinycarlo: a done obstacle ends the episode, it pays nothing
    assert info["termination"] == "obstacle"
    assert info["obstacles_hit"] == ["#ff0000"]
    assert "obstacles" not in info["reward_terms"]
    assert not any(t for _, _, t in steps[:-1])


@pytest.mark.parametrize("outside, fires", [(1, False), (-1, True)])
def test_colour_beside_the_footprint(tmp_path, outside, fires):
    """Lines 1 px outside each side of the path never fire; 1 px inside they do."""
    image = blank()
    half = TRACK_WIDTH // 2
    image[300 - half - outside, 200:] = BGR["red"]  # ahead of the start (a spawn on an
    image[300 + half + outside, 200:] = BGR["red"]  # obstacle colour is refused)
    steps = drive_straight(obstacle_env(tmp_path, image, (60.0, 300.0, 0.0)), 35)
    assert len(steps) == 35
    hits = [bool(info["obstacles_hit"]) for info, _, _ in steps]
    assert any(hits) == fires
    if fires:  # from the step the car's nose reaches the lines on
        assert all(hits[hits.index(True) :]) and hits.index(True) > 0


def test_obstacles_match_brute_force_while_turning(tmp_path):
    """Random specks; a weaving drive; every step compared with a brute-force footprint test."""
    rng = np.random.default_rng(1)
    image = blank(800, 800)
    for _ in range(150):
        x, y = rng.integers(100, 700, 2)
        side = rng.integers(1, 5)
        image[y : y + side, x : x + side] = BGR["red"]
    image[140:260, 380:540] = 0  # the start clear (a spawn on an obstacle colour is refused)
    ys, xs = np.nonzero(color_mask(image[..., ::-1], BGR["red"], tolerance=0))
    specks = np.stack([xs, ys], axis=1).astype(float)
    env = obstacle_env(tmp_path, image, (400.0, 200.0, 0.0), velocity=200.0)
    env.reset(seed=0)
    hits = 0
    for k in range(150):  # about one lap of a wobbly circle of radius ~200 px
        steer = 0.8 + 0.2 * math.sin(k / 5)
        _, _, terminated, _, info = env.step(np.array([steer], np.float32))
        assert not terminated
        margins = footprint_margin(specks, info["pose"])
        if np.any(np.abs(margins) < 1e-6):
            continue  # a centre exactly on the edge: either answer would be defensible
        assert bool(info["obstacles_hit"]) == bool(np.any(margins > 0)), k
        hits += bool(info["obstacles_hit"])
    assert hits >= 10  # the drive really met the specks


def test_touched_obstacles_counts_pixel_centres_inside(tmp_path):
    """The narrow phase alone, on random rectangles (some axis-aligned) vs brute force."""
    rng = np.random.default_rng(0)
    size = 120
    image = np.zeros((size, size, 4), np.uint8)
    image[..., 3] = 255
    red = Color.rgb(255, 0, 0)
    ys, xs = np.mgrid[0:size, 0:size]
    centres = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(float)
    for trial in range(400):
        heading = rng.choice([0.0, math.pi / 2, math.pi, rng.uniform(-math.pi, math.pi)])
        length, width = rng.uniform(3, 50), rng.uniform(3, 30)
        pose = (*rng.uniform(30, 90, 2), heading)
        if trial % 3 == 0:  # integer corners: centres exactly on edges count
            pose, length, width = (*np.round(pose[:2]), heading), round(length), round(width)
        margins = footprint_margin(centres, pose, length, width).reshape(size, size)
        near = np.argwhere(np.abs(margins) < 1.5)
        py, px = near[rng.integers(len(near))]
        image[..., :3] = 0
        image[py, px, 0] = 255
        image[rng.integers(size, size=3), rng.integers(size, size=3), 0] = 255  # other specks
        if trial % 4 == 1:  # a blob: its cell boxes may lie wholly inside the footprint
            h, w = rng.integers(1, 40, 2)
            image[py : py + h, px : px + w, 0] = 255
        cells, owners = _obstacle_cells(image, (red,))
        track = ImageTrack(image, ((0, 0, 0),), (red,), cells, owners, None, None, "-")
        exact = heading in (0.0, math.pi / 2, math.pi) and trial % 3 == 0  # integer corners
        f = np.array([math.cos(heading), math.sin(heading)])
        f = np.round(f) if exact else f  # cos(pi / 2) is 6e-17, not 0
        r = np.array([-f[1], f[0]])
        rear = np.array(pose[:2])
        left, right = rear - r * width / 2, rear + r * width / 2
        corners = np.array([left, right, right + length * f, left + length * f])
        red_centres = np.argwhere(image[..., 0] == 255)[:, ::-1].astype(float)
        red_margins = footprint_margin(red_centres, pose, length, width)
        expected = np.any(red_margins >= -1e-9)
        if not exact and not np.any(red_margins > 1e-9) and expected:
            continue  # on a slanted edge to rounding: either answer would be defensible
        found = ObstaclePixels(track).touched(corners, range(len(cells)))
        assert bool(found) == expected, (trial, margins[py, px])


def random_polygon(rng: np.random.Generator, trial: int) -> np.ndarray:
    """A footprint-like rectangle: integer or half-pixel corners, axis-aligned or turned,
    either winding, sometimes without area."""
    heading = rng.choice([0.0, math.pi / 2, math.pi, math.pi / 4, rng.uniform(-4, 4)])
    f = np.array([math.cos(heading), math.sin(heading)])
    f = np.round(f) if trial % 3 == 0 and heading != math.pi / 4 else f
    r = np.array([-f[1], f[0]])
    rear = rng.uniform(0, 40, 2)
    rear = np.round(rear * 2) / 2 if trial % 2 else rear
    length, width = rng.integers(0, 30, 2) if trial % 4 else rng.uniform(0, 30, 2)
    left, right = rear - r * width / 2, rear + r * width / 2
    corners = np.array([left, right, right + length * f, left + length * f])
    return corners[::-1].copy() if trial % 5 == 0 else corners


def test_scalar_span_and_box_tests_agree_with_the_array_ones():
    """The per-pixel span test and the one-corner-per-edge box test give the answers of
    _row_spans and of testing all four box corners, bit for bit, edges and ties included."""
    rng = np.random.default_rng(1)
    xs = np.mgrid[-5:50, -25:70][1]
    for trial in range(300):
        corners = random_polygon(rng, trial)
        rows = np.arange(-5, 50, dtype=np.float64)
        left, right = _row_spans(corners, rows)
        expected = (xs >= np.ceil(left)[:, None]) & (xs <= np.floor(right)[:, None])
        spans = _span_edges(corners.tolist())
        found = [[_inside_span(spans, float(x), float(y)) for x in range(-25, 70)] for y in rows]
        assert np.array_equal(np.array(found), expected), trial
        edges = _inner_edges(corners.tolist())
        for _ in range(20):
            x0, y0 = np.round(rng.uniform(-10, 50, 2)) - 0.5
            x1, y1 = x0 + rng.integers(1, 12), y0 + rng.integers(1, 12)
            every_corner = all(
                dx * (y - ay) - dy * (x - ax) >= 0
                for ax, ay, dx, dy, *_ in edges
                for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))
            )
            assert _box_inside([x0, y0, x1, y1], edges) == every_corner


# -- cross-track error ----------------------------------------------------------------------


def cte_env(tmp_path, image, spawn, cte=None, cameras=None, **kwargs):
    cross_track_error = {"use_cte": True, "trajectory_color": [0, 255, 0], **(cte or {})}
    config = {
        "car": {"wheelbase": WHEELBASE, "velocity": 300},
        "reward_design": {"cross_track_error": cross_track_error},
        "tracks": [{"image": "track.png", "spawns": [list(spawn)]}],
    }
    if cameras:
        config["cameras"] = cameras
    return make_env(write_track(tmp_path, image, config), **kwargs)


@pytest.mark.parametrize("offset", [0.0, 7.0, -23.0, 61.5])
def test_cte_is_the_distance_to_a_straight_trajectory(tmp_path, offset):
    image = blank(400, 600)
    image[200, :] = BGR["green"]
    env = cte_env(tmp_path, image, (100.0, 200.0 + offset, 0.0))
    _, info = env.reset(seed=0)
    errors = [info["cte"]]
    for _ in range(10):
        errors.append(env.step(straight())[4]["cte"])
    np.testing.assert_allclose(errors, abs(offset), atol=1.0)


@pytest.mark.parametrize("offset", [12.0, -40.0])
def test_cte_to_a_slanted_trajectory(tmp_path, offset):
    import cv2

    image = blank(600, 600)
    angle = math.radians(30)
    start, end = (0, 100), (600, 100 + round(600 * math.tan(angle)))
    cv2.line(image, start, end, BGR["green"], 1, cv2.LINE_8)
    # a spawn ``offset`` px off the line (along its normal), driving parallel to it
    x = 150.0
    y = 100 + x * math.tan(angle)
    spawn = (x - offset * math.sin(angle), y + offset * math.cos(angle), angle)
    env = cte_env(tmp_path, image, spawn)
    _, info = env.reset(seed=0)
    errors = [info["cte"]] + [env.step(straight())[4]["cte"] for _ in range(8)]
    np.testing.assert_allclose(errors, abs(offset), atol=1.0)


def test_trajectory_is_hidden_from_cameras_and_drawn_in_the_overview(tmp_path):
    image = blank(400, 600)
    image[228:232, :] = BGR["green"]  # 30 px to the car's right, across every camera's view
    image[168:172, :] = BGR["blue"]  # a marking 30 px to the left, for contrast
    cameras = [
        {"id": "front", "resolution": [60, 80], "roi": [120, 160]},
        {"id": "right", "resolution": [60, 80], "roi": [120, 160], "yaw": 90},
    ]
    env = cte_env(tmp_path, image, (100.0, 200.0, 0.0), cameras=cameras, render_mode="rgb_array")
    observation, _ = env.reset(seed=0)
    for _ in range(3):
        for frame in observation.values():
            assert not color_mask(frame, BGR["green"], tolerance=100).any()
        assert color_mask(observation["front"], BGR["blue"]).any()  # markings are shown
        observation, *_ = env.step(straight())
    overview = env.render()
    assert color_mask(overview[225:235, 300:], BGR["green"], tolerance=0).any()
    # without use_cte, the same colour is an ordinary marking the cameras show
    plain = cte_env(tmp_path / "plain", image, (100.0, 200.0, 0.0), {"use_cte": False}, cameras)
    observation, info = plain.reset(seed=0)
    assert color_mask(observation["front"], BGR["green"]).any()
    assert "cte" not in info


def test_cte_shaping_callable(tmp_path):
    image = blank(400, 600)
    image[200, :] = BGR["green"]
    env = cte_env(tmp_path, image, (100.0, 213.0, 0.1), cte_shaping=lambda e: 5.0 - e / 4)
    env.reset(seed=0)
    seen = set()
    for _ in range(10):
        _, reward, _, _, info = env.step(straight())
        assert reward == pytest.approx(5.0 - info["cte"] / 4)
        assert info["reward_terms"] == {"cte": pytest.approx(reward)}
        seen.add(round(info["cte"]))
    assert len(seen) > 3  # the error changed along the drive


SHAPINGS = {
    "linear": lambda e, s, w: -w * e / s,
    "quadratic": lambda e, s, w: -w * (e / s) ** 2,
    "exponential": lambda e, s, w: w * math.exp(-e / s),
    "gaussian": lambda e, s, w: w * math.exp(-((e / s) ** 2) / 2),
}


@pytest.mark.parametrize("kind", SHAPINGS)
def test_cte_shaping_from_yaml(tmp_path, kind):
    image = blank(400, 600)
    image[200, :] = BGR["green"]
    scale, weight = 20.0, 3.0
    cte = {"shaping": kind, "scale": scale, "weight": weight}
    env = cte_env(tmp_path, image, (100.0, 150.0, 0.3), cte)
    env.reset(seed=0)
    errors = []
    for _ in range(12):
        _, reward, _, _, info = env.step(straight())
        assert reward == pytest.approx(SHAPINGS[kind](info["cte"], scale, weight))
        errors.append(info["cte"])
    assert max(errors) > 2 * scale and min(errors) < scale  # the drive nears the line


def test_no_cte_reward_without_shaping(tmp_path):
    image = blank(400, 600)
    image[200, :] = BGR["green"]
    env = cte_env(tmp_path, image, (100.0, 240.0, 0.0))
    env.reset(seed=0)
    _, reward, _, _, info = env.step(straight())
    assert info["cte"] == pytest.approx(40) and reward == 0.0


# -- NearestPoint ---------------------------------------------------------------------------

coordinate = st.floats(-3000, 3000, allow_nan=False)
far = st.floats(-1e6, 1e6, allow_nan=False)


def assert_nearest(points: np.ndarray, queries, cell: float) -> None:
    index = NearestPoint(points, cell)
    for x, y in queries:
        distance, nx, ny = index.query(x, y)
        # a second query reads the cell's cached candidates; a copy starts with none
        assert index.query(x, y) == (distance, nx, ny)
        assert pickle.loads(pickle.dumps(index)).query(x, y) == (distance, nx, ny)
        brute = np.sqrt(((points - (x, y)) ** 2).sum(axis=1))
        assert distance == pytest.approx(brute.min(), rel=1e-12, abs=1e-9)
        assert math.hypot(nx - x, ny - y) == pytest.approx(distance, rel=1e-12, abs=1e-9)
        assert np.any(np.all(points == (nx, ny), axis=1))  # the answer is one of the points


@settings(max_examples=examples(300), deadline=None)
@given(
    st.lists(st.tuples(coordinate, coordinate), min_size=1, max_size=80),
    st.lists(st.tuples(far, far), min_size=1, max_size=8),
    st.sampled_from([7.5, 32.0, 500.0]),  # [px]; the grid spans (extent / cell) ** 2 cells
)
def test_nearest_point_matches_brute_force(points, queries, cell):
    assert_nearest(np.array(points), queries, cell)


@settings(max_examples=examples(200), deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(-5, 5), st.integers(-5, 5), st.sampled_from([0, 2000, -9000])),
        min_size=1,
        max_size=60,
    ),
    st.lists(st.tuples(coordinate, coordinate), min_size=1, max_size=8),
)
def test_nearest_point_on_far_apart_pixel_clusters(pixels, queries):
    """Integer pixels in a few tight clusters far apart: mostly empty cells between them."""
    points = np.array([(x + c, y - c // 3) for x, y, c in pixels], float)
    assert_nearest(points, queries, 32.0)


@settings(max_examples=examples(200), deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 200), st.integers(0, 200)), min_size=1, max_size=80),
    st.lists(st.tuples(st.integers(0, 400), st.integers(0, 400)), min_size=1, max_size=8),
)
def test_nearest_point_inside_the_grid_keeps_ties(pixels, halves):
    """Queries inside the grid, on half pixels and cell edges (many ties): the cached
    candidates of a cell give the very point that a search of every point gives."""
    points = np.array(pixels, float)
    index = NearestPoint(points, 8.0)
    for hx, hy in halves:
        x, y = hx / 2, hy / 2
        col = min(max(math.floor((x - index.origin[0]) / 8.0), 0), index.cols - 1)
        row = min(max(math.floor((y - index.origin[1]) / 8.0), 0), index.rows - 1)
        xs, ys = index._candidates(row, col, index.rows + index.cols)  # every point
        d2 = (xs - x) ** 2 + (ys - y) ** 2
        best = int(np.argmin(d2))
        assert index.query(x, y) == (math.sqrt(d2[best]), xs[best], ys[best])


def test_nearest_point_far_outside():
    points = np.array([[0.0, 0.0], [10.0, 0.0], [5000.0, 5000.0]])
    index = NearestPoint(points)
    assert index.query(-1e5, 0.0) == pytest.approx((1e5, 0.0, 0.0))
    assert index.query(12.0, -1e5)[1:] == (10.0, 0.0)
    assert index.query(1e7, 1e7)[1:] == (5000.0, 5000.0)
    with pytest.raises(ValueError):
        NearestPoint(np.zeros((0, 2)))
