"""Tracks in metres, round 5: a newcomer's stadium as a cone map and as a centreline."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tinyrace.config import ConfigError, load_env_config
from tinyrace.errors import problem_count
from tinyrace.tracks.metric import MetricSource
from tinyrace.validate import build_course, picture


def stadium(
    radius: float, half: float = 4.0, step: float = 0.8, arc_points: int = 11
) -> list[tuple[float, float]]:
    """Points counter-clockwise round a stadium: straights y = -radius and +radius from
    x = -half to half, half circles of ``radius`` about (+-half, 0); starts at (-half, -radius)."""
    points = [(x, -radius) for x in np.arange(-half, half, step)]
    arc = np.linspace(-math.pi / 2, math.pi / 2, arc_points)[:-1]
    points += [(half + radius * math.cos(a), radius * math.sin(a)) for a in arc]
    points += [(x, radius) for x in np.arange(half, -half, -step)]
    points += [
        (-half + radius * math.cos(a + math.pi), radius * math.sin(a + math.pi)) for a in arc
    ]
    return [(float(x), float(y)) for x, y in points]


def cone_rows(blue: list[tuple[float, float]], yellow: list[tuple[float, float]]) -> list[str]:
    rows = [f"blue,{x:.3f},{y:.3f},0,0,0,0" for x, y in blue]
    rows += [f"yellow,{x:.3f},{y:.3f},0,0,0,0" for x, y in yellow]
    return rows


def write_cones(folder: Path, rows: list[str], separator: str = ",", **track: object) -> Path:
    header = "tag,x,y,direction,x_variance,y_variance,covariance"
    text = "\n".join(row.replace(",", separator) for row in [header, *rows]) + "\n"
    (folder / "cones.csv").write_text(text)
    knobs = "".join(f", {key}: {value}" for key, value in track.items())
    (folder / "track.yaml").write_text(
        "track: {type: cone_map, file: cones.csv" + knobs + "}\n"
        "car: {model: kinematic_throttle, wheelbase: 0.33, track_width: 0.31, velocity: 5.0}\n"
    )
    return folder


def load(folder: Path) -> MetricSource:
    loaded = load_env_config(environment=folder)
    return MetricSource(loaded.config, loaded.base_dir, loaded.source)


def problems(folder: Path) -> list[str]:
    with pytest.raises(ConfigError) as caught:
        load(folder)
    return [str(p) for p in caught.value.problems]


# -- 1. a gap in one edge's cones ------------------------------------------------------------
def test_a_whole_stadium_of_cones_loads(tmp_path):
    track = load(write_cones(tmp_path, cone_rows(stadium(2.0), stadium(4.0)))).tracks[0]
    assert track.centerline is not None
    widths = track.circuit.widths.sum(axis=1)
    assert widths.min() > 1.8 and widths.max() < 2.3  # 2 m between the edges all round


def test_a_hairpin_whose_inner_cones_stand_far_round_the_outer_edge_loads(tmp_path):
    """EUFS's Hairpin track: inner cones 2.6 m apart at the end of a 1.5 m radius turn while
    the outer edge runs some 20 m round it. A check that refused neighbours beside which
    the other edge runs more than max_cone_gap further refused it (and two more of EUFS's
    tracks); a gap shorter than max_cone_gap is not told from such a turn."""
    inner = stadium(1.5, step=2.6, arc_points=3)
    outer = stadium(5.0, step=2.6, arc_points=15)
    track = load(write_cones(tmp_path, cone_rows(inner, outer))).tracks[0]
    widths = track.circuit.widths.sum(axis=1)
    assert widths.min() > 2.5 and widths.max() < 4.5


def test_a_gap_wider_than_max_cone_gap_in_a_straight_line_is_named_as_before(tmp_path):
    folder = write_cones(tmp_path, cone_rows(blue_with_a_gap(), stadium(4.0)), max_cone_gap=3)
    (message,) = problems(folder)
    assert "neighbours at most 3 m apart" in message and "5.66 m away" in message


def blue_with_a_gap() -> list[tuple[float, float]]:
    """The inner (blue) cones without the right half circle and the straight's last 3 m
    before it (about 10 m of cones): the cones either side, (0, -2) and (4, 2), are 5.66 m
    apart across the infield, nearer than max_cone_gap's default 6 m."""
    return [p for p in stadium(2.0) if not (p[0] > 0.5 and p[1] < 1.95)]


# -- 2. the advice of a start that overlaps a cone -----------------------------------------
BIG_ORANGE = ["big_orange,0.000,-1.700,0,0,0,0", "big_orange,0.000,-4.300,0,0,0,0"]


def test_a_cone_map_start_is_beside_its_big_orange_cones_else_its_first_blue_cone(tmp_path):
    rows = cone_rows(stadium(2.0), stadium(4.0))
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    x, y, _ = load(write_cones(tmp_path / "a", rows + BIG_ORANGE)).tracks[0].spawns[0]
    assert abs(x) < 0.3 and y == pytest.approx(-3.0, abs=0.05)  # between them, x = 0
    x, y, _ = load(write_cones(tmp_path / "b", rows)).tracks[0].spawns[0]
    assert math.hypot(x + 4.0, y + 2.0) < 1.5  # beside the first blue cone, (-4, -2)


def test_a_car_start_row_places_the_car_and_the_start_line_stays_at_the_big_orange_cones(
    tmp_path,
):
    """EUFS's tracks end with a ``car_start,x,y,direction,...`` row: the car's start pose."""
    rows = cone_rows(stadium(2.0), stadium(4.0)) + BIG_ORANGE
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    with_start = load(write_cones(tmp_path / "a", [*rows, "car_start,-2.5,-3.0,0.1,0.01,0.01,0"]))
    without = load(write_cones(tmp_path / "b", rows))
    assert with_start.tracks[0].spawns[0] == (-2.5, -3.0, 0.1)
    assert without.tracks[0].spawns[0] != (-2.5, -3.0, 0.1)
    # the same road, laps counted from the same line
    assert np.array_equal(with_start.tracks[0].centerline, without.tracks[0].centerline)


@pytest.mark.parametrize(
    ("extra", "where", "says"),
    [
        (["car_start,0,-3,0", "car_start,1,-3,0"], "line", "expected one car_start row"),
        (["car_start,zero,-3,0"], "column 2 (x)", "the car's start pose is x, y, direction"),
        (["car_start,0,-3,east"], "column 4 (direction)", "a finite number within"),
        (["car_start,0,0,0"], "line", "expected the car's start on the road between the cones"),
    ],
)
def test_a_bad_car_start_row_is_named(tmp_path, extra, where, says):
    (message,) = problems(write_cones(tmp_path, cone_rows(stadium(2.0), stadium(4.0)) + extra))
    assert where in message and says in message


def test_a_cone_map_start_on_a_cone_says_what_moves_it_not_track_spawn(tmp_path):
    folder = write_cones(tmp_path, cone_rows(stadium(2.0), stadium(4.0)) + BIG_ORANGE)
    text = (folder / "track.yaml").read_text().replace("wheelbase: 0.33", "wheelbase: 2.5")
    (folder / "track.yaml").write_text(text.replace("track_width: 0.31", "track_width: 1.6"))
    with pytest.raises(ConfigError) as caught:
        build_course(load_env_config(environment=folder))
    (problem,) = caught.value.problems
    assert problem.path == "track.file" and "overlaps a cone" in problem.allowed
    assert "track.spawn" not in problem.allowed  # a cone map refuses that key
    assert (
        "big_orange cones" in problem.allowed
        and "move the car_start row or those cones" in problem.allowed
    )
    assert problem.allowed.endswith("make the car smaller (car.wheelbase, car.track_width)")


# -- 4. separators, and long lists of problems ---------------------------------------------
@pytest.mark.parametrize("separator", [";", "\t", ", "])
def test_a_cone_map_takes_the_separators_a_centreline_csv_takes(tmp_path, separator):
    rows = cone_rows(stadium(2.0), stadium(4.0)) + BIG_ORANGE
    (tmp_path / "comma").mkdir()
    (tmp_path / "other").mkdir()
    comma = load(write_cones(tmp_path / "comma", rows)).tracks[0]
    other = load(write_cones(tmp_path / "other", rows, separator)).tracks[0]
    assert np.array_equal(comma.cones, other.cones)
    assert np.array_equal(comma.centerline, other.centerline)


def test_a_long_list_of_problems_says_how_many_more_it_leaves_out(tmp_path):
    rows = [row.replace("blue", "purple").replace("yellow", "purple") for row in
            cone_rows(stadium(2.0), stadium(4.0))]  # fmt: skip
    found = problems(write_cones(tmp_path, rows))
    assert len(found) == 21 and all("'purple'" in line for line in found[:20])
    assert found[20].endswith(f"... and {len(rows) - 20} more problem(s) like these, not listed")
    with pytest.raises(ConfigError) as caught:
        load(tmp_path)
    assert problem_count(caught.value.problems) == len(rows)
    assert str(caught.value).startswith(f"{len(rows)} configuration problems:")


def test_validate_counts_the_problems_it_does_not_list(tmp_path):
    rows = [f"{k},0.0,-1,1" for k in range(30)]  # 30 negative widths
    (tmp_path / "c.csv").write_text("# x_m,y_m,w_tr_right_m,w_tr_left_m\n" + "\n".join(rows))
    (tmp_path / "track.yaml").write_text("track: {type: centerline, file: c.csv}\n")
    done = subprocess.run(
        [sys.executable, "-m", "tinyrace", "validate", str(tmp_path / "track.yaml")],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 1
    assert "... and 10 more problem(s) like these, not listed" in done.stdout
    assert done.stderr.strip().endswith("30 problem(s) found")


# -- 5. the road-width rule's message ------------------------------------------------------
def write_circle(folder: Path, radius: float, left: float) -> Path:
    angles = np.linspace(0, 2 * math.pi, 90, endpoint=False)
    rows = [f"{radius * math.cos(a):.4f},{radius * math.sin(a):.4f},1.0,{left}" for a in angles]
    (folder / "c.csv").write_text("# x_m,y_m,w_tr_right_m,w_tr_left_m\n" + "\n".join(rows))
    (folder / "track.yaml").write_text("track: {type: centerline, file: c.csv, spacing: 0.5}\n")
    return folder


def test_a_road_folding_past_the_limit_says_the_limit_and_why_it_is_above_one(tmp_path):
    (message,) = problems(write_circle(tmp_path, 10.0, 14.0))  # 1.4 x the radius
    assert "at most 1.2 x the curve's radius" in message and "(1.41 x)" in message
    assert "Above 1 x the inner edge passes the curve's centre" in message
    assert "up to 1.2 x is let through only because surveyed circuits'" in message


def test_a_road_up_to_the_limit_loads(tmp_path):
    assert load(write_circle(tmp_path, 10.0, 11.0)).tracks[0].centerline is not None  # 1.1 x


# -- 6. the shipped circuit's comment: advice that works -----------------------------------
def test_the_circuit_tracks_advice_for_a_real_circuit_works_both_ways(tmp_path):
    shipped = Path(__file__).resolve().parents[1] / "example_tracks" / "circuit"
    text = (shipped / "track.yaml").read_text()
    assert "copy racetrack-database/tracks/Monza.csv into this" in text
    assert "files: {paths_outside_folder: true}" in text
    outside = tmp_path / "racetrack-database" / "tracks"
    outside.mkdir(parents=True)
    monza = (shipped / "circuit.csv").read_text()  # a stand-in for Monza.csv
    (outside / "Monza.csv").write_text(monza)
    copied, pointed = tmp_path / "copied", tmp_path / "pointed"
    for folder in (copied, pointed):
        folder.mkdir()
    (copied / "Monza.csv").write_text(monza)
    (copied / "track.yaml").write_text(text.replace("file: circuit.csv", "file: Monza.csv"))
    absolute = text.replace("file: circuit.csv", f"file: {outside / 'Monza.csv'}")
    (pointed / "track.yaml").write_text(absolute)
    assert any("paths_outside_folder" in line for line in problems(pointed))  # refused so far
    (pointed / "track.yaml").write_text(absolute + "files: {paths_outside_folder: true}\n")
    for folder in (copied, pointed):
        assert len(load(folder).tracks[0].centerline) == 1085  # the whole circuit


# -- 7. tinyrace show frames a small track on its road -------------------------------------
def test_show_frames_a_small_centreline_track_on_its_road_not_its_playfield(tmp_path):
    (tmp_path / "c.csv").write_text(
        "# x_m,y_m\n" + "\n".join(f"{x:.4f},{y - 3:.4f}" for x, y in stadium(3.0, step=0.2))
    )
    (tmp_path / "track.yaml").write_text("track: {type: centerline, file: c.csv, spacing: 0.25, "
                                         "default_width: 1.6}\n")  # fmt: skip
    track = load(tmp_path).tracks[0]
    x0, y0, x1, y1 = track.bounds
    assert (x1 - x0, y1 - y0) == pytest.approx((115.6, 107.6), abs=0.1)  # the playfield stays
    image = picture(str(tmp_path), 0).image
    height, width, _ = image.shape
    assert width == 1600 and height == pytest.approx(1600 * 9.6 / 17.6, abs=5)  # the road and 1 m
    grey = (np.abs(image.astype(int) - image[..., :1]).max(axis=2) < 8) & (image[..., 0] > 60)
    assert grey.mean() > 0.25  # the road (and the legend's box aside) fills the picture


# -- 3. the start faces along a straight that begins there ---------------------------------
@pytest.mark.parametrize("spacing", [2.0, 0.25])
@pytest.mark.parametrize("first", [0, -1])  # the straight ahead of the start, or behind it
def test_a_start_where_a_straight_meets_a_curve_faces_along_the_straight(tmp_path, spacing, first):
    points = stadium(3.0, step=0.2, arc_points=61)  # the curve's chords under 0.25 m
    if first == -1:  # driven the other way round: the straight behind the start
        points = [points[0], *points[:0:-1]]
    rows = "\n".join(f"{x:.4f},{y:.4f},0.8,0.8" for x, y in points)
    (tmp_path / "c.csv").write_text("# x_m,y_m,w_tr_right_m,w_tr_left_m\n" + rows)
    (tmp_path / "track.yaml").write_text(
        f"track: {{type: centerline, file: c.csv, spacing: {spacing}}}\n"
    )
    track = load(tmp_path).tracks[0]
    x, y, heading = track.spawns[0]
    assert (x, y) == (-4.0, -3.0)
    assert heading == (0.0 if first == 0 else math.pi)  # exactly along the straight
    start = track.tiles[0]  # its first edge (left_0, right_0) is square to the straight
    assert start[0][0] == pytest.approx(start[1][0], abs=1e-12)
    assert track.circuit.headings[0] == heading


@pytest.mark.parametrize("spacing", [2.0, 0.5, 0.05])
@pytest.mark.parametrize("arc_points", [3, 5, 25])
def test_the_start_faces_along_the_straight_at_any_spacing(tmp_path, spacing, arc_points):
    """Judged on the resampled points, a spacing finer than the file's last chord made the
    points behind the start lie in line too, and the heading leaned toward the corner again
    (-0.196 rad with a 4-chord arc at spacing 0.5): the file's own points decide."""
    points = stadium(3.0, step=0.5, arc_points=arc_points)
    rows = "\n".join(f"{x:.4f},{y:.4f},0.8,0.8" for x, y in points)
    (tmp_path / "c.csv").write_text("# x_m,y_m,w_tr_right_m,w_tr_left_m\n" + rows)
    (tmp_path / "track.yaml").write_text(
        f"track: {{type: centerline, file: c.csv, spacing: {spacing}}}\n"
    )
    assert load(tmp_path).tracks[0].spawns[0][2] == 0.0


def test_a_start_on_a_curve_keeps_the_tangent_from_its_two_neighbours(tmp_path):
    angles = np.linspace(0, 2 * math.pi, 200, endpoint=False)
    rows = "\n".join(f"{10 * math.cos(a):.6f},{10 * math.sin(a):.6f},1,1" for a in angles)
    (tmp_path / "c.csv").write_text("# x_m,y_m,w_tr_right_m,w_tr_left_m\n" + rows)
    (tmp_path / "track.yaml").write_text("track: {type: centerline, file: c.csv, spacing: 2}\n")
    track = load(tmp_path).tracks[0]
    line = track.centerline
    chord = line[1] - line[-1]
    assert track.spawns[0][2] == math.atan2(chord[1], chord[0])  # pi / 2 within 1e-3
    assert track.spawns[0][2] == pytest.approx(math.pi / 2, abs=1e-3)


def test_a_car_start_direction_is_bounded_as_a_spawns_heading(tmp_path):
    rows = [*cone_rows(stadium(2.0), stadium(4.0)), *BIG_ORANGE, "car_start,-2.5,-3,1e300"]
    (message,) = problems(write_cones(tmp_path, rows))
    assert "column 4 (direction)" in message and "within +-1e+09 [rad]" in message


def test_a_stray_cone_far_from_the_road_is_named(tmp_path):
    """A cone 50 km away stretched the playfield (and the ground's pixels) to reach it, and
    tinyrace show drew the track 2 px high."""
    rows = [*cone_rows(stadium(2.0), stadium(4.0)), *BIG_ORANGE, "orange,-50000,0,0,0,0,0"]
    (message,) = problems(write_cones(tmp_path, rows))
    assert "line" in message and "[-50000.0, 0.0]" in message
    assert "within 100 m of the road" in message and "49,99" in message
    near = [*cone_rows(stadium(2.0), stadium(4.0)), *BIG_ORANGE, "orange,-60,0,0,0,0,0"]
    (tmp_path / "near").mkdir()
    assert load(write_cones(tmp_path / "near", near)).tracks[0].centerline is not None
