"""The lidar's two ray-casting paths, the numpy passes and the compiled numba kernel, give the
same float32 ranges and hit classes bit for bit, on any map, origin and heading; which path
a lidar takes, and what each builds."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.kernels import compiled as compiled_module
from tinyrace.kernels.compiled import compiler
from tinyrace.sensors.kernels import raycast as raycast_numba
from tinyrace.sensors.lidar import KERNEL_VARIABLE, LidarSensor, beam_angles, kernel
from tinyrace.sensors.machinery import raycast, raycast_numpy
from tinyrace.sensors.machinery.raycast import (
    FINE_STEP,
    SECTOR_SLOPES,
    SECTORS,
    SKIP_BLOCKED,
    SKIP_MARGIN,
    TABLE_RANGE,
)

FANS = [(1, 1.0), (2, 1.0), (7, 1.0), (7, 90.0), (360, 360.0), (1080, 270.0), (1080, 360.0)]


def blocking_maps() -> st.SearchStrategy[np.ndarray]:
    """Boolean maps: scattered cells, walls (rectangles) and discs, from empty to crowded."""

    @st.composite
    def make(draw):
        height, width = draw(st.integers(20, 260)), draw(st.integers(20, 260))
        rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
        blocking = rng.random((height, width)) < draw(st.sampled_from([0.0, 0.001, 0.01, 0.1]))
        rows, cols = np.mgrid[:height, :width]
        for _ in range(draw(st.integers(0, 6))):
            r, c = rng.integers(0, height), rng.integers(0, width)
            if rng.random() < 0.5:
                blocking[r : r + rng.integers(1, 30), c : c + rng.integers(1, 30)] = True
            else:
                blocking |= np.hypot(rows - r, cols - c) <= rng.uniform(0.3, 12)
        return blocking

    return make()


@st.composite
def frames(draw, shape: tuple[int, int]) -> tuple[np.ndarray, bool]:
    """A track -> cell affine of a map of ``shape`` (cell size, y up or down, any rotation,
    perhaps mirrored) and whether the track is y-down."""
    cell = draw(st.sampled_from([0.05, 0.3, 1.0, 1.7, 18.75]))  # [track units]
    turn = draw(st.sampled_from([0.0, math.pi / 2, draw(st.floats(-math.pi, math.pi))]))
    mirror = draw(st.booleans())
    c, s = math.cos(turn) / cell, math.sin(turn) / cell
    linear = np.array([[c, -s], [s, c]]) @ np.diag([1.0, -1.0 if mirror else 1.0])
    centre = np.array(shape[::-1], np.float64) / 2
    offset = centre - linear @ (centre * cell)
    return np.column_stack([linear, offset]), draw(st.booleans())


def scans(field_numpy, field_numba, angles, max_range, y_down, origins, headings):
    """Ranges of both paths from every origin and heading."""
    fans = [
        raycast.beam_fan(field, angles, max_range, y_down, tables)
        for field, tables in ((field_numpy, True), (field_numba, False))
    ]
    for origin in origins:
        for heading in headings:
            first, reverse = raycast.fan_angle(field_numpy, angles, heading, y_down)
            a = raycast_numpy.cast(field_numpy, fans[0], origin, first, reverse)
            b = raycast_numba.cast(field_numba, fans[1], origin, first, reverse)
            yield a, b


@settings(max_examples=examples(60), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), blocking=blocking_maps())
def test_both_paths_give_the_same_ranges_bit_for_bit(data, blocking):
    to_cells, y_down = data.draw(frames(blocking.shape))
    cell = 1 / math.sqrt(abs(np.linalg.det(to_cells[:, :2])))  # [track units]
    # ranges within the tables, and far past them (sphere tracing)
    reach = data.draw(st.sampled_from([0.5, 5.0, 40.0, 80.0, 119.9, 121.0, 300.0]))  # [cells]
    max_range = reach * cell
    # (beams, fov [deg]); the numpy path's tables grow as 1 / the angle between beams
    beams, fov = data.draw(st.sampled_from(FANS))
    angles = beam_angles(beams, math.radians(fov))
    fields = [
        raycast.distance_field(blocking, to_cells, reach=reach, near=near) for near in (True, False)
    ]
    if data.draw(st.booleans()):  # the compiled kernel with its skip maps by direction
        fields[1] = raycast_numba.with_sectors(fields[1])
        assert fields[1].sectors is not None
    height, width = blocking.shape
    corners = np.array([[0, 0], [width, height]], np.float64)  # [cells], and a little beyond
    inverse = np.linalg.inv(np.vstack([to_cells, [0, 0, 1]]))[:2]
    points = st.tuples(st.floats(-0.1, 1.1), st.floats(-0.1, 1.1)).map(
        lambda f: tuple(inverse @ (*(corners[0] + f * (corners[1] - corners[0])), 1.0))
    )
    origins = data.draw(st.lists(points, min_size=1, max_size=4))
    headings = data.draw(st.lists(st.floats(-10.0, 10.0), min_size=1, max_size=3))
    for a, b in scans(*fields, angles, max_range, y_down, origins, headings):
        assert a.dtype == b.dtype == np.float32
        np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32))


def test_the_paths_agree_on_a_crowded_map_in_the_numpy_paths_every_branch():
    """Many false alarms (the numpy path's loop over next flagged segments), few (its
    whole-row pass), beams that hit nothing in the tables and march on, origins in walls."""
    rng = np.random.default_rng(7)
    blocking = rng.random((300, 300)) < 0.004
    blocking[150, :140] = True  # a wall the beams along it graze
    to_cells = np.array([[1.0, 0, 0], [0, 1.0, 0]])
    angles = beam_angles(1080, 2 * math.pi)
    fields = [raycast.distance_field(blocking, to_cells, reach=250.0, near=n) for n in (1, 0)]
    origins = [(151.3, 152.6), (40.0, 151.0), (150.0, 150.0), (10.2, 290.9), (-5.0, 3.0)]
    headings = [0.0, 0.001, math.pi / 4, 2.0]
    compared = 0
    for numba_field in (fields[1], raycast_numba.with_sectors(fields[1])):
        for a, b in scans(fields[0], numba_field, angles, 250.0, False, origins, headings):
            np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32))
            compared += 1
    assert compared == 2 * len(origins) * len(headings)


@pytest.mark.parametrize(
    ("folder", "blocks"),
    [("autocross", ["walls", "cones"]), ("formula_student", None), ("f1tenth_loop", None)],
)
def test_lidar_sensors_on_both_paths_observe_the_same_ranges_and_classes(folder, blocks):
    config = {"id": "lidar", "type": "lidar", "beams": 541, "fov": 270, "hit_classes": True}
    if blocks:
        config["blocks"] = blocks
    env = gym.make("tinyrace/TinyRace-v0", environment=str(TRACKS_DIR / folder), sensors=[config])
    env.reset(seed=1)
    env.action_space.seed(1)
    raw = env.unwrapped
    lidar = next(s for s in raw.sensors if isinstance(s, LidarSensor))
    twins = {
        name: LidarSensor(lidar.config, lidar.max_range, lidar.cell, lidar.cone_colors, name)
        for name in ("numpy", "numba")
    }
    for twin in twins.values():
        twin.reset(raw.layout)
    hits = 0
    for _ in range(30):
        env.step(env.action_space.sample())
        snapshot = raw.snapshot()
        seen = [twin.observe(snapshot, raw.layout, None) for twin in twins.values()]
        for key in ("ranges", "classes"):
            np.testing.assert_array_equal(seen[0][key], seen[1][key])
        hits += int((seen[0]["classes"] > 0).sum())
    assert hits > 0
    env.close()


def test_the_skip_map_never_skips_a_blocked_sample():
    """From a free cell with skip n > 0, every cell whose centre is within n FINE_STEPs plus
    two half diagonals is free (brute force over all pairs of a small map)."""
    rng = np.random.default_rng(3)
    blocking = rng.random((40, 50)) < 0.02
    blocking[5:9, 30:44] = True
    field = raycast.distance_field(blocking, np.array([[1.0, 0, 0], [0, 1.0, 0]]), near=False)
    height, width = field.shape
    lead = raycast.LEAD * width
    skips = field.skips[lead : lead + height * width].reshape(height, width)
    blocked = np.argwhere(field.blocking() > 0)
    free = np.argwhere(field.blocking() == 0)
    nearest = np.sqrt(((free[:, None, :] - blocked[None, :, :]) ** 2).sum(-1)).min(1)
    n = skips[free[:, 0], free[:, 1]].astype(np.float64)
    skipping = n > 0  # 0: the next sample is looked at
    assert skipping.mean() > 0.5
    assert (n * FINE_STEP + math.sqrt(2) < nearest)[skipping].all()
    assert (n * FINE_STEP + SKIP_MARGIN + FINE_STEP > nearest).all()  # and skips what it can
    assert (skips[field.blocking() > 0] == SKIP_BLOCKED).all()


def _sector_maps(field: raycast.DistanceField) -> np.ndarray:
    """(SECTORS, s H, s w) view of a field's sector skip maps, s = its sector_scale."""
    height, width = np.array(field.shape) * field.sector_scale
    lead = raycast.LEAD * field.sector_scale * width
    assert field.sectors is not None
    return field.sectors[lead : lead + SECTORS * height * width].reshape(SECTORS, height, width)


@pytest.mark.parametrize("scale", raycast_numba.SECTOR_SCALES)
def test_the_sector_maps_never_skip_a_blocked_sample(scale, monkeypatch):
    """From any point of a free cell, along any direction (those on the sectors' edges too),
    the samples that the skip of the point's sector map cell passes over are all in free
    cells (brute force: every sample's cells computed as the kernel computes them)."""
    monkeypatch.setattr(raycast_numba, "SECTOR_SCALES", (scale,))
    rng = np.random.default_rng(5)
    blocking = rng.random((60, 70)) < 0.02
    blocking[10:13, 5:60] = True  # walls that beams run along
    blocking[20:50, 40] = True
    field = raycast_numba.with_sectors(
        raycast.distance_field(blocking, np.array([[1.0, 0, 0], [0, 1.0, 0]]), near=False)
    )
    assert field.sector_scale == scale
    blocked = field.blocking() > 0
    maps = _sector_maps(field)
    edges = np.arctan2(np.arange(SECTOR_SLOPES + 1), SECTOR_SLOPES)  # [rad] first eighth
    edges = np.concatenate([edges + k * np.pi / 2 for k in range(4)])
    edges = np.concatenate([edges, np.pi / 2 - edges])  # every sector's edges, all eighths
    angles = np.concatenate([rng.uniform(-np.pi, np.pi, 40000), np.tile(edges, 400)])
    c, s = np.cos(angles), np.sin(angles)
    free = np.argwhere(~blocked)
    row, col = free[rng.integers(0, len(free), len(angles))].T
    on_edge = rng.random(len(angles)) < 0.3  # points on the edges and corners of cells
    edge = [-0.5, -0.25, 0.0, 0.2499999, 0.4999999]  # of the cell and its sector map cells
    dx = np.where(on_edge, rng.choice(edge, len(angles)), rng.uniform(-0.5, 0.5, len(angles)))
    dy = np.where(on_edge, rng.choice(edge, len(angles)), rng.uniform(-0.5, 0.5, len(angles)))
    height, width = blocked.shape
    for start in (0, 37):  # the point is sample ``start`` of a beam from an origin behind it
        radius = (start + 1 + np.arange(SKIP_BLOCKED)) * FINE_STEP  # [cells] that sample on
        x0, y0 = col + dx - c * radius[0], row + dy - s * radius[0]
        x, y = x0[:, None] + c[:, None] * radius, y0[:, None] + s[:, None] * radius
        tx, ty = x + 0.5, y + 0.5  # as the kernel rounds them
        cx, cy = np.floor(tx).astype(np.int64), np.floor(ty).astype(np.int64)
        fine_x, fine_y = (np.floor(t[:, 0] * scale).astype(np.int64) for t in (tx, ty))
        assert (fine_x // scale == cx[:, 0]).all() and (fine_y // scale == cy[:, 0]).all()
        skips = maps[raycast.sector(c, s), fine_y, fine_x].astype(np.int64)
        free = skips < SKIP_BLOCKED  # (rounding may move a point on an edge to a wall)
        assert free.mean() > 0.97
        inside = (cx >= 0) & (cx < width) & (cy >= 0) & (cy < height)
        hit = ~inside
        hit[inside] = blocked[cy[inside], cx[inside]]
        skipped = np.arange(SKIP_BLOCKED)[None, :] <= skips[:, None]
        skipped[:, 0] = False  # the point itself
        assert not (hit & skipped & free[:, None]).any()
        assert (skips[free] > 8).mean() > 0.3


def test_the_sector_maps_skip_more_along_a_corridor():
    """In a corridor 9 cells wide, beams along it skip several times farther than the
    direction-blind skip map lets them; the sector maps never skip less."""
    blocking = np.ones((40, 200), bool)
    blocking[15:24, :] = False
    field = raycast_numba.with_sectors(
        raycast.distance_field(blocking, np.array([[1.0, 0, 0], [0, 1.0, 0]]), near=False)
    )
    height, width = field.shape
    lead = raycast.LEAD * width
    skips = field.skips[lead : lead + height * width].reshape(height, width)
    scale = field.sector_scale
    maps = _sector_maps(field)[:, ::scale, ::scale]  # a sector map cell in each cell
    free = field.blocking() == 0
    assert (maps[:, free] >= skips[free]).all()
    along = maps[raycast.sector(np.array([1.0]), np.array([0.05]))[0]]
    middle = np.s_[raycast.PAD + 19, raycast.PAD + 20 : raycast.PAD + 100]
    assert along[middle].mean() > 3 * skips[middle].mean()


def test_sector_maps_are_as_fine_as_fit():
    """Sector maps take SECTORS times scale**2 the skip map's bytes: a small field gets the
    finest, a large one coarser ones, a very large one none (its one skip map serves)."""
    budget = raycast_numba.SECTOR_BYTES
    fine, coarse = raycast_numba.SECTOR_SCALES[0], raycast_numba.SECTOR_SCALES[-1]
    for side, scale in ((50, fine), (math.isqrt(budget // SECTORS // fine**2) + 1, coarse)):
        field = raycast.distance_field(np.zeros((side, side), bool), np.eye(2, 3), near=False)
        assert raycast_numba.with_sectors(field).sector_scale == scale
    side = math.isqrt(budget // SECTORS // coarse**2) + 1
    large = raycast.distance_field(np.zeros((side, side), bool), np.eye(2, 3), near=False)
    assert raycast_numba.with_sectors(large) is large


def test_each_path_builds_only_what_it_needs(monkeypatch):
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment=str(TRACKS_DIR / "circuit"),
        sensors=[{"id": "lidar", "type": "lidar", "beams": 1080}],
    )
    env.reset(seed=0)
    raw = env.unwrapped
    lidar = next(s for s in raw.sensors if isinstance(s, LidarSensor))
    assert lidar.kernel == "numba"  # numba is a test dependency: the default path when present
    assert lidar.fan.coarse is None and lidar.fan.fine is None and lidar.field.near is None
    assert lidar.field.skips is not None
    monkeypatch.setenv(KERNEL_VARIABLE, "numpy")
    twin = LidarSensor(lidar.config, lidar.max_range, lidar.cell, lidar.cone_colors)
    twin.reset(raw.layout)
    assert twin.kernel == "numpy" and twin.field.skips is None
    assert twin.fan.coarse is not None and twin.fan.fine is not None
    assert twin.fan.fine.nbytes > 10 * 2**20  # the tables the compiled kernel does without
    env.close()


def test_the_variable_chooses_the_path(monkeypatch):
    monkeypatch.setenv(KERNEL_VARIABLE, "numpy")
    assert kernel() == ("numpy", raycast_numpy.cast)
    monkeypatch.setenv(KERNEL_VARIABLE, "NumBa")
    assert kernel() == ("numba", raycast_numba.cast)
    monkeypatch.delenv(KERNEL_VARIABLE)
    assert kernel()[0] == "numba"
    assert kernel("numpy")[0] == "numpy"  # an explicit choice wins over the variable
    monkeypatch.setenv(KERNEL_VARIABLE, "fortran")
    with pytest.raises(ValueError, match="auto, numba or numpy"):
        kernel()


def test_an_uncachable_kernel_still_compiles(monkeypatch):
    """numba refuses cache=True when no cache directory is writable: compile uncached."""
    calls = []

    def njit(**options):
        calls.append(options)
        if options.get("cache"):
            raise RuntimeError("cannot cache function 'f': no locator available")
        return lambda function: function

    monkeypatch.setattr(compiled_module, "njit", njit)
    with pytest.warns(UserWarning, match="cannot cache the lidar kernel"):
        compiled = compiler("lidar")(math.hypot)
    assert compiled is math.hypot and calls == [{"cache": True, "nogil": True}, {"nogil": True}]


def test_no_sample_leaves_the_lead_rows():
    """The kernel indexes without clipping: the tables' reach stays inside the LEAD rows."""
    assert TABLE_RANGE + 2 < raycast.LEAD


def test_beams_too_dense_for_the_numpy_tables_are_a_config_error_not_gigabytes(monkeypatch):
    """1080 beams over 1 deg would need about 7.7 GB of numpy sample tables: refused before
    anything is built, naming the entry, the knobs and the way out; the compiled path, which
    needs no tables, takes the same lidar."""
    dense = [{"id": "lidar", "type": "lidar", "beams": 1080, "fov": 1.0}]
    circuit = str(TRACKS_DIR / "circuit")
    assert raycast.table_bytes(beam_angles(1080, math.radians(1.0))) > 4 * 2**30
    monkeypatch.setenv(KERNEL_VARIABLE, "numpy")
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment=circuit, sensors=dense)
    text = str(caught.value)
    for part in ("sensors[0]", "beams: 1080", "fov: 1.0", "MB", "compiled path (numba"):
        assert part in text
    default = [{"id": "lidar", "type": "lidar", "beams": 1080, "fov": 270.0}]
    gym.make("tinyrace/TinyRace-v0", environment=circuit, sensors=default).close()
    monkeypatch.setenv(KERNEL_VARIABLE, "numba")
    env = gym.make("tinyrace/TinyRace-v0", environment=circuit, sensors=dense)
    observation, _ = env.reset(seed=0)
    assert observation["lidar"].shape == (1080,)
    env.close()
