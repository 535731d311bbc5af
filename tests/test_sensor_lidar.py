"""Lidar core against geometry: a circular wall and a square room, noise and dropout; the
geometry on both ray-casting paths (numpy passes and the compiled numba kernel)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tinyrace.sensors.kernels import raycast as raycast_numba
from tinyrace.sensors.lidar import add_noise, beam_angles, directions
from tinyrace.sensors.machinery import raycast, raycast_numpy
from tinyrace.sensors.machinery.raycast import beam_fan, fan_angle

SIZE = 401  # cells per side of the test maps
PATHS = ["numpy", "numba"]


@pytest.fixture(params=PATHS)
def distance_field(request):
    """``raycast.distance_field`` made for one ray-casting path; its fields remember it."""

    def make(*args, **kwargs):
        if request.param == "numpy":
            return raycast.distance_field(*args, near=True, **kwargs)
        return raycast_numba.with_sectors(raycast.distance_field(*args, near=False, **kwargs))

    return make


def _scan(field, origin, angles, max_range: float, heading: float = 0.0) -> np.ndarray:
    """Ranges of beams at evenly spaced ``angles`` [rad] from a car at ``heading`` on a y-up
    map, as the lidar sensor casts them, on the path ``field`` was made for."""
    angles = np.asarray(angles, np.float64)
    numpy = field.near is not None
    fan = beam_fan(field, angles, max_range, tables=numpy)
    cast = raycast_numpy.cast if numpy else raycast_numba.cast
    return cast(field, fan, origin, *fan_angle(field, angles, heading, y_down=False))


def _centres(cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Track coordinates of every cell centre, and the track -> cell affine (origin at the map
    centre, y up, ``cell`` track units per cell)."""
    half = (SIZE - 1) / 2
    to_cells = np.array([[1 / cell, 0, half], [0, -1 / cell, half]])
    cols, rows = np.meshgrid(np.arange(SIZE), np.arange(SIZE))
    return (cols - half) * cell, (half - rows) * cell, to_cells


@pytest.mark.parametrize("cell", [0.05, 1.0])
@pytest.mark.parametrize("radius_cells", [30, 150])
def test_circular_wall_from_its_centre(cell, radius_cells, distance_field):
    x, y, to_cells = _centres(cell)
    radius = radius_cells * cell
    blocking = np.hypot(x, y) >= radius
    field = distance_field(blocking, to_cells)
    angles = np.linspace(-math.pi, math.pi, 1080, endpoint=False)
    ranges = _scan(field, (0.0, 0.0), angles, max_range=10 * radius)
    assert ranges.dtype == np.float32 and ranges.shape == (1080,)
    tolerance = max(cell, 0.01 * radius)
    assert np.abs(ranges - radius).max() <= tolerance


@pytest.mark.parametrize("origin", [(0.0, 0.0), (12.3, -30.7), (-55.0, 48.0)])
def test_square_room_gives_the_analytic_ranges(origin, distance_field):
    cell = 0.5
    x, y, to_cells = _centres(cell)
    half_side = 80.25  # walls at |x| = |y| = 80.25: the edges of the cells centred on 80.5
    blocking = (np.abs(x) > half_side) | (np.abs(y) > half_side)
    field = distance_field(blocking, to_cells)
    angles = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    ranges = _scan(field, origin, angles, max_range=1000.0)
    c, s = np.cos(angles), np.sin(angles)
    ox, oy = origin
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (half_side - ox) / c, (-half_side - ox) / c)
        ty = np.where(s > 0, (half_side - oy) / s, (-half_side - oy) / s)
    expected = np.minimum(np.abs(tx), np.abs(ty))
    assert np.abs(ranges - expected).max() <= cell


def test_beyond_max_range_reports_max_range_and_inside_a_wall_zero(distance_field):
    x, _, to_cells = _centres(1.0)
    blocking = np.abs(x) >= 100
    field = distance_field(blocking, to_cells)
    ranges = _scan(field, (0.0, 0.0), [0.0, math.pi / 2, math.pi], max_range=50.0)
    np.testing.assert_array_equal(ranges, [50.0, 50.0, 50.0])
    assert _scan(field, (150.0, 0.0), [0.0], max_range=50.0)[0] == 0.0


def test_a_flipped_map_measures_the_same_distances(distance_field):
    """y-down maps (image tracks): the affine's flip must not change ranges."""
    cell = 1.0
    x, _, to_cells = _centres(cell)
    blocking = x >= 60.5
    down = to_cells * [[1], [-1]] + [[0, 0, 0], [0, 0, SIZE - 1]]
    up = _scan(distance_field(blocking, to_cells), (0, 0), [0.0, 0.5], 500.0)
    flipped = _scan(distance_field(blocking[::-1], down), (0, 0), [0.0, 0.5], 500.0)
    np.testing.assert_allclose(up, flipped, atol=1e-4)
    assert abs(up[0] - 60.0) <= cell and abs(up[1] - 60.0 / math.cos(0.5)) <= cell


def test_beam_angles_cover_the_fov_rightmost_first():
    angles = beam_angles(5, math.pi)
    np.testing.assert_allclose(angles, [-math.pi / 2, -math.pi / 4, 0, math.pi / 4, math.pi / 2])
    full = beam_angles(4, 2 * math.pi)
    np.testing.assert_allclose(full, [-math.pi, -math.pi / 2, 0, math.pi / 2])


def test_noise_and_dropout_follow_the_generator():
    ranges = np.full(20000, 10.0, np.float32)
    a = add_noise(ranges, np.random.default_rng(3), std=0.1, dropout=0.2, max_range=30.0)
    b = add_noise(ranges, np.random.default_rng(3), std=0.1, dropout=0.2, max_range=30.0)
    np.testing.assert_array_equal(a, b)
    dropped = a == 30.0
    assert 0.18 < dropped.mean() < 0.22
    assert abs(np.std(a[~dropped]) - 0.1) < 0.01 and abs(np.mean(a[~dropped]) - 10.0) < 0.01
    clean = add_noise(ranges, np.random.default_rng(3), std=0.0, dropout=0.0, max_range=30.0)
    np.testing.assert_array_equal(clean, ranges)


def test_directions_turn_with_the_heading_and_the_image_convention():
    up = directions(np.array([0.0, math.pi / 2]), math.pi / 2, y_down=False)
    np.testing.assert_allclose(up, [[0, 1], [-1, 0]], atol=1e-12)  # + left: counter-clockwise
    down = directions(np.array([math.pi / 2]), 0.0, y_down=True)
    np.testing.assert_allclose(down, [[0, -1]], atol=1e-12)  # left of +x is up the image


@pytest.mark.parametrize(("cell", "max_range"), [(0.19375, 3.3), (0.3, 7.0), (0.07, 30.0)])
def test_a_beam_that_hits_nothing_reports_max_range_exactly(cell, max_range, distance_field):
    # cells whose max_range in cells, divided back, rounds past max_range in float32
    side = int(2 * max_range / cell) + 20
    field = distance_field(
        np.zeros((side, side), bool), np.array([[1 / cell, 0, 0], [0, 1 / cell, 0]])
    )
    centre = side * cell / 2
    ranges = _scan(field, (centre, centre), beam_angles(360, 2 * math.pi), max_range)
    assert (ranges == np.float32(max_range)).all()


def test_the_edge_of_the_map_blocks_where_it_is(distance_field):
    """Beams that leave an empty map stop at its edge, not wherever a step took them."""
    cell = 1.0
    _, _, to_cells = _centres(cell)
    field = distance_field(np.zeros((SIZE, SIZE), bool), to_cells)
    half = SIZE / 2 * cell  # [track units] centre to the outer side of the last cells
    ranges = _scan(field, (0.0, 0.0), [0.0, math.pi / 2, math.pi], max_range=10 * half)
    np.testing.assert_allclose(ranges, [half, half, half], atol=cell)


def test_ranges_match_dense_sampling_on_a_random_map(distance_field):
    """Away from corners clipped by less than half a cell, every range is within half a
    cell of the first blocking cell found by sampling each beam every 1/100 cell."""
    rng = np.random.default_rng(0)
    blocking = rng.random((SIZE, SIZE)) < 0.01
    _, _, to_cells = _centres(1.0)
    field = distance_field(blocking, to_cells)
    angles = beam_angles(720, 2 * math.pi)
    origin = (0.0, 0.0)  # the centre of a cell: the tables' origin is exact
    ranges = _scan(field, origin, angles, max_range=60.0)
    t = np.arange(0, 60.0, 0.01)
    ends = np.rint(
        to_cells[:, 2] + t[:, None, None] * np.stack([np.cos(angles), -np.sin(angles)], axis=1)
    ).astype(int)  # (T, B, 2) cells of every dense sample, y up on the map
    hit = blocking[ends[..., 1], ends[..., 0]]
    first = np.where(hit.any(0), t[hit.argmax(0)], 60.0)
    assert 0.3 < (first < 60.0).mean() < 0.7  # many beams hit something, many do not
    error = np.abs(ranges - first)
    close = error <= 1.0
    assert close.mean() > 0.9 and error[close].max() <= 0.5 * 1.01  # half a fine step
    # the rest clipped a corner the samples stepped over (salt and pepper has many): longer
    assert (ranges[~close] > first[~close]).all()
