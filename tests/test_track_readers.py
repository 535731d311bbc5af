"""The readers of tracks in metres: centreline CSV, cone map, ROS map and raceline.

Data is generated here (an ellipse, a figure eight, broken rows) or by the example
generator; every bad file must be a ConfigError naming the file and the line.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tinyrace.config.schema import FilesConfig
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.tracks import polyline
from tinyrace.tracks.centerline_csv import read_loop
from tinyrace.tracks.circuit import Circuit
from tinyrace.tracks.cone_map import read_cones, road_between
from tinyrace.tracks.ros_map import read_map

HEADER = "# x_m,y_m,w_tr_right_m,w_tr_left_m\n"
METRIC_EXAMPLES = ("circuit/circuit.csv", "autocross/cones.csv", "f1tenth_loop/map.yaml")


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def loop_csv(points: np.ndarray, right: float = 5.0, left: float = 5.0) -> str:
    return HEADER + "".join(f"{x:.6f},{y:.6f},{right},{left}\n" for x, y in points)


def ellipse(a: float, b: float, count: int) -> np.ndarray:
    t = np.linspace(0, 2 * math.pi, count, endpoint=False)
    return np.column_stack((a * np.cos(t), b * np.sin(t)))


def ramanujan_perimeter(a: float, b: float) -> float:
    h = ((a - b) / (a + b)) ** 2
    return math.pi * (a + b) * (1 + 3 * h / (10 + math.sqrt(4 - 3 * h)))


def problem_paths(error: pytest.ExceptionInfo) -> list[str]:
    return [p.path for p in error.value.problems]


# -- centreline CSV ------------------------------------------------------------------------------
@pytest.mark.parametrize("spacing", [1.0, 5.0])
def test_an_ellipse_loads_with_its_analytic_perimeter(tmp_path, spacing):
    a, b = 400.0, 180.0  # [m]
    path = write(tmp_path, "ellipse.csv", loop_csv(ellipse(a, b, 500)))
    loop = read_loop(path, "track.yaml", "track.file")
    circuit = Circuit.build(loop.points, loop.widths, spacing)
    assert circuit.length == pytest.approx(ramanujan_perimeter(a, b), rel=0.005)
    steps = polyline.segment_lengths(circuit.centerline)
    assert steps == pytest.approx(np.full(len(steps), circuit.spacing), rel=1e-3)


def test_the_scale_multiplies_lengths_and_widths(tmp_path):
    path = write(tmp_path, "e.csv", loop_csv(ellipse(40, 20, 200), right=2.0, left=3.0))
    loop = read_loop(path, "t", "k", scale=0.5)
    assert np.abs(loop.points).max() == pytest.approx(20.0)
    assert loop.widths[0].tolist() == [1.0, 1.5]


def test_the_start_faces_the_direction_of_travel_and_the_left_edge_is_left(tmp_path):
    path = write(tmp_path, "c.csv", loop_csv(ellipse(50, 50, 100), right=1.0, left=3.0))
    loop = read_loop(path, "t", "k")
    circuit = Circuit.build(loop.points, loop.widths, 1.0)
    x, y, heading = circuit.start_pose
    assert (x, y) == pytest.approx((50.0, 0.0))
    assert heading == pytest.approx(math.pi / 2, abs=1e-3)  # counter-clockwise
    left, right = circuit.edges()
    assert np.hypot(*left[0]) == pytest.approx(47.0, abs=1e-3)  # inside: left of travel
    assert np.hypot(*right[0]) == pytest.approx(51.0, abs=1e-3)


def test_tiles_cover_the_road_between_the_edges(tmp_path):
    path = write(tmp_path, "c.csv", loop_csv(ellipse(50, 50, 100), right=2.0, left=2.0))
    loop = read_loop(path, "t", "k")
    circuit = Circuit.build(loop.points, loop.widths, 1.0)
    area = sum(abs(polyline.signed_area(quad)) for quad in circuit.tiles)
    assert area == pytest.approx(math.pi * (52**2 - 48**2), rel=0.01)


def test_a_figure_eight_names_the_crossing_lines(tmp_path):
    t = np.linspace(0, 2 * math.pi, 40, endpoint=False)
    eight = np.column_stack((100 * np.sin(t), 50 * np.sin(2 * t)))
    path = write(tmp_path, "eight.csv", loop_csv(eight))
    with pytest.raises(ConfigError) as error:
        read_loop(path, "t", "k")
    (problem,) = error.value.problems
    assert problem.source == str(path)
    assert problem.path.startswith("lines ") and " and " in problem.path
    assert "cross" in problem.allowed


def test_fewer_than_four_points_is_an_error(tmp_path):
    path = write(tmp_path, "few.csv", HEADER + "0,0,1,1\n10,0,1,1\n5,5,1,1\n")
    with pytest.raises(ConfigError) as error:
        read_loop(path, "t", "k")
    assert error.value.problems[0].source == str(path)
    assert "at least 4" in str(error.value)


@pytest.mark.parametrize(
    ("row", "where"),
    [
        ("10,0,-1,2", "line 3, column 3 (w_tr_right_m)"),
        ("10,0,1,-2", "line 3, column 4 (w_tr_left_m)"),
        ("10,nan,1,2", "line 3, column 2"),
        ("10,inf,1,2", "line 3, column 2"),
        ("10,zero,1,2", "line 3, column 2"),
        ("10,0,1", "line 3"),
    ],
)
def test_a_bad_row_names_the_file_line_and_column(tmp_path, row, where):
    rows = ["0,0,1,1", row, "10,10,1,1", "0,10,1,1"]
    path = write(tmp_path, "bad.csv", HEADER + "\n".join(rows) + "\n")
    with pytest.raises(ConfigError) as error:
        read_loop(path, "t", "k")
    assert error.value.problems[0].source == str(path)
    assert problem_paths(error)[0] == where


def test_a_missing_file_names_the_config_key(tmp_path):
    with pytest.raises(ConfigError) as error:
        read_loop(tmp_path / "nope.csv", "exp.yaml", "track.file")
    (problem,) = error.value.problems
    assert (problem.source, problem.path) == ("exp.yaml", "track.file")


def test_a_raceline_is_read_by_its_header_names(tmp_path):
    points = ellipse(10, 5, 60)
    rows = [f"{i}; {x}; {y}; 99; 0; 3; 0" for i, (x, y) in enumerate(points)]
    text = "# a\n# b\n# s_m; x_m; y_m; psi_rad; kappa_radpm; vx_mps; ax_mps2\n" + "\n".join(rows)
    loop = read_loop(write(tmp_path, "race.csv", text), "t", "k")
    assert np.allclose(loop.points, points)
    assert loop.widths is None
    # headings come from the points (psi is ignored: 99 would be absurd)
    assert polyline.headings(loop.points)[0] == pytest.approx(math.pi / 2, abs=0.01)


def test_plain_xy_waypoints_load(tmp_path):
    points = ellipse(10, 5, 30)
    text = "".join(f"{x}, {y}\n" for x, y in points)
    assert np.allclose(read_loop(write(tmp_path, "w.csv", text), "t", "k").points, points)


# -- cone map ------------------------------------------------------------------------------------
def test_the_example_cone_map_gives_a_road_with_blue_on_the_left():
    cones = read_cones(TRACKS_DIR / "autocross" / "cones.csv", "t", "k")
    road = road_between(cones, 1.0, 6.0)
    assert road.widths.min() > 1.8 and road.widths.max() < 2.2  # a 4 m lane [m]
    normal = polyline.left_normals(road.centerline)
    blue = cones.positions[cones.of("blue")]
    nearest = [polyline.nearest_index(road.centerline, p) for p in blue]
    side = np.sum((blue - road.centerline[nearest]) * normal[nearest], axis=1)
    assert (side > 0).all()
    start = cones.positions[cones.of("big_orange")].mean(axis=0)
    assert np.hypot(*(road.centerline[0] - start)) < 1.0


def test_a_cone_map_driven_the_other_way_round_is_reversed(tmp_path):
    source = (TRACKS_DIR / "autocross" / "cones.csv").read_text()
    swapped = source.replace("blue,", "tmp,").replace("yellow,", "blue,").replace("tmp,", "yellow,")
    cones = read_cones(write(tmp_path, "c.csv", swapped), "t", "k")
    original = road_between(read_cones(TRACKS_DIR / "autocross" / "cones.csv", "t", "k"), 1, 6)
    road = road_between(cones, 1.0, 6.0)
    assert polyline.signed_area(road.centerline) * polyline.signed_area(original.centerline) < 0


@pytest.mark.parametrize(
    ("row", "where"),
    [
        ("purple,1,2,0,0,0,0", "line 3, column 1 (tag)"),
        ("blue,1,x,0,0,0,0", "line 3, column 3 (y)"),
        ("blue,nan,1,0,0,0,0", "line 3, column 2 (x)"),
        ("blue,1", "line 3"),
    ],
)
def test_a_bad_cone_row_names_the_file_line_and_column(tmp_path, row, where):
    text = "tag,x,y,direction,x_variance,y_variance,covariance\nblue,0,0,0,0,0,0\n" + row + "\n"
    path = write(tmp_path, "c.csv", text)
    with pytest.raises(ConfigError) as error:
        read_cones(path, "t", "k")
    assert error.value.problems[0].source == str(path)
    assert problem_paths(error) == [where]


def test_cones_that_do_not_close_a_loop_name_the_line_of_the_gap(tmp_path):
    lines = ["tag,x,y,direction,x_variance,y_variance,covariance"]
    lines += [f"blue,{x},0,0,0,0,0" for x in (0, 3, 6, 30)]
    lines += [f"yellow,{x},-4,0,0,0,0" for x in (0, 3, 6, 9)]
    path = write(tmp_path, "c.csv", "\n".join(lines) + "\n")
    with pytest.raises(ConfigError) as error:
        road_between(read_cones(path, "t", "k"), 1.0, 6.0)
    (problem,) = error.value.problems
    assert problem.source == str(path) and problem.path == "line 4"  # the cone at x = 6


# -- ROS map -------------------------------------------------------------------------------------
def map_folder(tmp_path: Path, yaml_text: str, picture: np.ndarray | None = None) -> Path:
    import cv2

    if picture is None:
        picture = np.full((4, 6), 254, np.uint8)
        picture[0, :] = 0  # top row occupied
        picture[3, 5] = 205  # unknown
    cv2.imwrite(str(tmp_path / "m.png"), picture)
    return write(tmp_path, "m.yaml", yaml_text)


GOOD_YAML = (
    "image: m.png\nresolution: 0.5\norigin: [10.0, -2.0, 0.0]\nnegate: 0\n"
    "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
)


def test_a_map_reads_free_and_occupied_cells_and_places_pixels_in_the_world(tmp_path):
    occupancy = read_map(map_folder(tmp_path, GOOD_YAML), "t", "k")
    assert occupancy.occupied[0].all() and not occupancy.occupied[1:].any()
    assert occupancy.free.sum() == 4 * 6 - 6 - 1
    # pixel (row 3, col 0) is the lower-left one: its centre is origin + (0.25, 0.25)
    assert occupancy.to_world(np.array([3]), np.array([0]))[0] == pytest.approx((10.25, -1.75))
    assert occupancy.to_world(np.array([0]), np.array([5]))[0] == pytest.approx((12.75, -0.25))
    points = np.array([[11.1, -0.3], [10.0, 5.0]])
    back = occupancy.to_pixel(points)
    assert occupancy.to_world(back[:, 0], back[:, 1]) == pytest.approx(points)
    assert occupancy.is_free(np.array([[10.25, -1.75], [10.25, -0.25], [0.0, 0.0]])).tolist() == [
        True,
        False,
        False,
    ]


def test_negate_inverts_the_occupancy(tmp_path):
    occupancy = read_map(
        map_folder(tmp_path, GOOD_YAML.replace("negate: 0", "negate: 1")), "t", "k"
    )
    assert occupancy.free[0].all() and occupancy.occupied[1:, :5].all()


def test_a_rotated_origin_turns_the_map(tmp_path):
    text = GOOD_YAML.replace("[10.0, -2.0, 0.0]", f"[0.0, 0.0, {math.pi / 2}]")
    occupancy = read_map(map_folder(tmp_path, text), "t", "k")
    assert occupancy.to_world(np.array([3]), np.array([0]))[0] == pytest.approx((-0.25, 0.25))


@pytest.mark.parametrize(
    ("old", "new", "where"),
    [
        ("resolution: 0.5", "resolution: -1", "line 2 (resolution)"),
        ("origin: [10.0, -2.0, 0.0]", "origin: [1, 2]", "line 3 (origin)"),
        ("negate: 0", "negate: 2", "line 4 (negate)"),
        ("free_thresh: 0.196", "free_thresh: 0.9", "line 6 (free_thresh)"),
        ("image: m.png", "image: missing.png", "line 1 (image)"),
    ],
)
def test_a_bad_map_yaml_names_the_file_and_line(tmp_path, old, new, where):
    path = map_folder(tmp_path, GOOD_YAML.replace(old, new))
    with pytest.raises(ConfigError) as error:
        read_map(path, "t", "k")
    (problem,) = error.value.problems
    assert (problem.source, problem.path) == (str(path), where)


def test_walls_are_outlines_of_the_occupied_cells():
    occupancy = read_map(TRACKS_DIR / "f1tenth_loop" / "map.yaml", "t", "k")
    segments = occupancy.wall_segments()
    assert 10 < len(segments) < 2000
    ends = segments.reshape(-1, 2)
    pixel = np.rint(occupancy.to_pixel(ends)).astype(int)
    assert occupancy.occupied[pixel[:, 0], pixel[:, 1]].all()


def test_the_example_raceline_runs_through_free_space_clear_of_the_walls():
    occupancy = read_map(TRACKS_DIR / "f1tenth_loop" / "map.yaml", "t", "k")
    raceline = read_loop(TRACKS_DIR / "f1tenth_loop" / "raceline.csv", "t", "k")
    assert occupancy.is_free(raceline.points).all()
    assert occupancy.clearance(raceline.points).min() > 0.8  # [m]


# -- the generator -------------------------------------------------------------------------------
def test_the_generator_rebuilds_the_committed_metric_examples(tmp_path):
    script = TRACKS_DIR / "make_metric_tracks.py"
    subprocess.run([sys.executable, str(script), str(tmp_path)], check=True)
    for folder in ("circuit", "autocross", "f1tenth_loop"):
        for made in (tmp_path / folder).iterdir():
            assert made.read_bytes() == (TRACKS_DIR / folder / made.name).read_bytes(), made


@pytest.mark.parametrize("name", METRIC_EXAMPLES)
def test_the_examples_read_without_problems(name):
    path = TRACKS_DIR / name
    if name.endswith("cones.csv"):
        assert len(road_between(read_cones(path, "t", "k"), 1.0, 6.0).centerline) > 100
    elif name.endswith(".yaml"):
        assert read_map(path, "t", "k").free.any()
    else:
        loop = read_loop(path, "t", "k")
        assert 2000 < polyline.perimeter(loop.points) < 2500


# -- bounded input (the same rules as track.yaml and its images) ----------------------------
def test_a_map_picture_outside_the_yaml_folder_is_refused(tmp_path):
    inner = tmp_path / "maps"
    inner.mkdir()
    map_folder(tmp_path, GOOD_YAML)  # m.png one folder up
    path = write(inner, "m.yaml", GOOD_YAML.replace("image: m.png", "image: ../m.png"))
    with pytest.raises(ConfigError) as error:
        read_map(path, "t", "k")
    (problem,) = error.value.problems
    assert (
        problem.source == str(path) and "image" in problem.path and "../m.png" in str(error.value)
    )
    allowed = FilesConfig(paths_outside_folder=True)
    assert read_map(path, "t", "k", allowed).free.any()  # the documented opt-in


def test_a_map_picture_above_the_pixel_cap_is_refused_before_decoding(tmp_path):
    path = map_folder(tmp_path, GOOD_YAML)  # a 4 x 6 picture
    with pytest.raises(ConfigError, match=r"m\.png"):
        read_map(path, "t", "k", FilesConfig(max_image_pixels=20))
    assert read_map(path, "t", "k", FilesConfig(max_image_pixels=24)).free.any()


def test_a_map_yaml_with_duplicate_keys_is_refused(tmp_path):
    path = map_folder(tmp_path, GOOD_YAML + "resolution: 0.1\n")
    with pytest.raises(ConfigError, match="resolution"):
        read_map(path, "t", "k")


def test_a_track_csv_that_is_a_fifo_is_refused_without_reading(tmp_path):
    fifo = tmp_path / "circuit.csv"
    os.mkfifo(fifo)  # reading it would block forever
    with pytest.raises(ConfigError) as error:
        read_loop(fifo, "exp.yaml", "track.file")
    (problem,) = error.value.problems
    assert (problem.source, problem.path) == ("exp.yaml", "track.file")
    assert "regular file" in problem.allowed
