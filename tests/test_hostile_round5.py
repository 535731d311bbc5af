"""Hostile input, fifth round: ROS maps, PGM pictures, start poses, roads and cones (a
helper's campaign of 354 cases on the F1TENTH inputs; these are the cases it found
mishandled).

A map with no occupied cell builds (no walls), a speckled one with too many walls is
refused; numbers too large for a float, an image name too long for the file system or
naming a folder get a ConfigError naming the key; a PGM whose white is not 255 is scaled as
the format says; ``mode: raw`` reads the occupancy in percent; a start pose taken from the
waypoints must lie on a free cell of the map; a road narrower than a car, a cone written
twice and cone edges that interleave are refused; a race pose that does not parse is named
once.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.config.image_file import read_image_bgr
from tinyrace.errors import ConfigError
from tinyrace.tracks.ros_map import pixel_rects, read_map

EXAMPLE = Path(__file__).parent / "data" / "f1tenth_example"
MAP_YAML = (
    "image: m.png\nresolution: 0.5\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
    "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
)


def map_folder(tmp_path: Path, text: str = MAP_YAML, picture: np.ndarray | None = None) -> Path:
    if picture is None:
        picture = np.full((6, 8), 254, np.uint8)
    cv2.imwrite(str(tmp_path / "m.png"), picture)
    (tmp_path / "m.yaml").write_text(text)
    return tmp_path / "m.yaml"


def problems_of(error: pytest.ExceptionInfo[ConfigError]) -> list[tuple[str, str]]:
    return [(p.path, p.allowed) for p in error.value.problems]


def test_a_map_without_occupied_cells_has_no_walls(tmp_path):
    occupancy = read_map(map_folder(tmp_path), "t", "k")
    assert occupancy.free.all() and not occupancy.occupied.any()
    assert pixel_rects(occupancy.occupied).shape == (0, 4)
    assert len(occupancy.wall_quads()) == 0


def test_a_speckled_map_with_too_many_walls_is_refused(tmp_path, monkeypatch):
    import tinyrace.tracks.ros_map as ros_map

    monkeypatch.setattr(ros_map, "MAX_MAP_WALLS", 20)
    picture = np.full((12, 12), 254, np.uint8)
    picture[::2, ::2] = 0  # 36 isolated occupied cells: 36 walls
    with pytest.raises(ConfigError) as caught:
        read_map(map_folder(tmp_path, picture=picture), "t", "k")
    ((key, allowed),) = problems_of(caught)
    assert key == "line 1 (image)"
    assert "at most 20 wall rectangles (they make at least 36: a speckled map?" in allowed
    picture[::2, ::2] = 254
    picture[:, 0] = 0  # one wall, a column of cells
    assert len(read_map(map_folder(tmp_path, picture=picture), "t", "k").wall_quads()) == 1


@pytest.mark.parametrize(
    "old, new, key",
    [
        ("resolution: 0.5", "resolution: " + "1" * 401, "line 2 (resolution)"),
        ("[0.0, 0.0, 0.0]", "[" + "9" * 401 + ", 0.0, 0.0]", "line 3 (origin)"),
        ("[0.0, 0.0, 0.0]", "[0.0, 0.0, " + "9" * 401 + "]", "line 3 (origin)"),
        ("free_thresh: 0.196", "free_thresh: " + "1" * 401, "line 6 (free_thresh)"),
    ],
)
def test_an_integer_too_large_for_a_float_names_its_key(tmp_path, old, new, key):
    with pytest.raises(ConfigError) as caught:
        read_map(map_folder(tmp_path, MAP_YAML.replace(old, new)), "t", "k")
    assert [path for path, _ in problems_of(caught)] == [key]


@pytest.mark.parametrize(
    "name, says",
    [("a" * 5000 + ".png", "cannot be read (File name too long)"), (".", "is not a file")],
)
def test_an_image_that_cannot_be_a_picture_names_the_key(tmp_path, name, says):
    text = MAP_YAML.replace("image: m.png", f"image: {name}")
    with pytest.raises(ConfigError) as caught:
        read_map(map_folder(tmp_path, text), "t", "k")
    ((path, allowed),) = problems_of(caught)
    assert path == "line 1 (image)"
    assert allowed.endswith(says) and len(allowed) < 200


def _pgm(path: Path, maxval: int, samples: np.ndarray) -> Path:
    height, width = samples.shape
    body = samples.astype(">u2" if maxval > 255 else np.uint8).tobytes()
    path.write_bytes(f"P5\n# CREATOR: map_saver\n{width} {height}\n{maxval}\n".encode() + body)
    return path


@pytest.mark.parametrize("maxval", [1, 100, 255, 1000, 65535])
def test_a_pgm_is_scaled_by_its_maxval(tmp_path, maxval):
    samples = np.array([[0, maxval // 2, maxval]])
    bgr = read_image_bgr(_pgm(tmp_path / "m.pgm", maxval, samples), 100, "t", "k")
    expected = np.rint(samples * 255 / maxval)
    assert np.abs(bgr[0, :, 0].astype(int) - expected).max() <= 1  # 65535: OpenCV's >> 8
    assert (bgr[..., 0] == bgr[..., 2]).all()


def test_a_map_saver_pgm_of_maxval_100_reads_free_and_occupied(tmp_path):
    samples = np.full((6, 8), 100)  # white: free
    samples[0] = 0  # black: occupied
    _pgm(tmp_path / "m.pgm", 100, samples)
    occupancy = read_map(map_folder(tmp_path, MAP_YAML.replace("m.png", "m.pgm")), "t", "k")
    assert occupancy.free[1:].all() and occupancy.occupied[0].all()


def test_raw_mode_reads_the_occupancy_in_percent(tmp_path):
    picture = np.zeros((6, 8), np.uint8)  # 0 %: free
    picture[0] = 100  # occupied
    picture[1, :4] = 255  # unknown
    picture[2, :4] = 40  # between the thresholds: not drivable, no wall
    text = MAP_YAML.replace("negate: 0", "negate: 1") + "mode: raw\n"  # raw ignores negate
    occupancy = read_map(map_folder(tmp_path, text, picture), "t", "k")
    assert occupancy.occupied[0].all() and not occupancy.occupied[1:].any()
    assert not occupancy.free[:3, :4].any() and occupancy.free[3:].all()


@pytest.mark.parametrize(
    "first_point, lies",
    [("1005.0,0.0", "outside the map"), ("1.5,0.0", "on a cell that is not free")],
)
def test_a_start_taken_from_the_waypoints_must_lie_on_a_free_cell(tmp_path, first_point, lies):
    shutil.copytree(EXAMPLE, tmp_path / "t")
    waypoints = tmp_path / "t" / "example_waypoints.csv"
    lines = waypoints.read_text().splitlines()
    header = [line for line in lines if line.startswith("#")]
    rows = [line for line in lines if line and not line.startswith("#")]
    x, y = (float(v) for v in first_point.split(","))
    columns = rows[0].split(";") if ";" in rows[0] else rows[0].split(",")
    sep = ";" if ";" in rows[0] else ","
    # the raceline's first row moved; its other columns as they were
    moved = [columns[0], f"{x}", f"{y}", *columns[3:]] if len(columns) > 3 else [f"{x}", f"{y}"]
    waypoints.write_text("\n".join([*header, sep.join(moved), *rows[1:]]) + "\n")
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment=str(tmp_path / "t"))
    ((path, allowed),) = problems_of(caught)
    assert path == "track.waypoints"
    assert f"lies {lies}" in allowed and "free cell of the map" in allowed


@pytest.mark.parametrize("width", [0.0, 0.02])
def test_a_road_narrower_than_a_car_is_refused(tmp_path, monkeypatch, width):
    monkeypatch.chdir(tmp_path)
    t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    rows = np.column_stack([30 * np.cos(t), 20 * np.sin(t), np.full(60, 3.0), np.full(60, 3.0)])
    rows[7, 2:] = width  # row 8 of the numbers, line 9 of the file (after the header)
    header = "x_m,y_m,w_tr_right_m,w_tr_left_m"
    np.savetxt(tmp_path / "oval.csv", rows, fmt="%.3f", delimiter=",", header=header)
    track = {"type": "centerline", "file": "oval.csv"}
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", track=track)
    ((key, allowed),) = problems_of(caught)
    assert key.startswith("line 9") and "expected a road at least 0.1 m wide" in allowed


def test_a_race_pose_that_does_not_parse_is_named_once():
    race = {"num_agents": 2, "start": "poses", "poses": [[13.29, 0, 1.73], [float("nan"), 0, 0]]}
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment="f1tenth_loop", race=race)
    assert [key for key, _ in problems_of(caught)] == ["race.poses[1][0]"]


def _cone_rows(interleaved: bool = False) -> list[str]:
    """A ring road of 24 blue cones (radius 14 m) and 24 yellow ones (10 m); interleaved: the
    two colours alternate on both circles, so the edges zig-zag across each other."""
    rows = []
    for i, t in enumerate(np.linspace(0, 2 * np.pi, 48, endpoint=False)):
        tag = "blue" if i % 2 == 0 else "yellow"
        r = (10 if (i // 2) % 2 == 0 else 14) if interleaved else (14 if tag == "blue" else 10)
        rows.append(f"{tag},{r * np.cos(t):.4f},{r * np.sin(t):.4f}")
    return rows


def _cone_env(tmp_path: Path, rows: list[str]) -> None:
    (tmp_path / "cones.csv").write_text("tag,x,y\n" + "\n".join(rows) + "\n")
    track = {"type": "cone_map", "file": "cones.csv"}
    gym.make("tinyrace/TinyRace-v0", track=track).close()


def test_a_cone_written_twice_is_refused_naming_both_lines(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rows = _cone_rows()
    _cone_env(tmp_path, rows)  # the ring itself is a road
    with pytest.raises(ConfigError) as caught:
        _cone_env(tmp_path, [*rows, rows[4]])
    ((key, allowed),) = problems_of(caught)
    assert key == "line 50" and allowed.endswith("line 6 has a cone there")


def test_cone_edges_that_interleave_are_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as caught:
        _cone_env(tmp_path, _cone_rows(interleaved=True))
    ((_, allowed),) = problems_of(caught)
    assert "expected a road at least 0.1 m wide between the blue and yellow cones" in allowed


def test_a_race_car_under_f1tenth_gym_compat_sets_the_clock_as_a_single_one_does():
    cars = [{"car": {"model": "single_track", "compat": "f1tenth_gym"}}, {}]
    env = gym.make("tinyrace/TinyRace-v0", environment="f1tenth_loop", race={"cars": cars})
    try:
        assert env.unwrapped.config.sim.fps == 100  # f1tenth_gym's 0.01 s step
    finally:
        env.close()
    with pytest.raises(ConfigError) as caught:
        gym.make(
            "tinyrace/TinyRace-v0",
            environment="f1tenth_loop",
            race={"cars": cars[::-1]},
            sim={"fps": 50},
        )
    ((key, allowed),) = problems_of(caught)
    assert key == "sim.fps"  # the one clock of every car, not a key of the entry
    assert allowed.endswith("(for race.cars[1].car)")


@pytest.mark.parametrize(
    "row, says",
    [
        ("60.0 0.0 5.0 5.0", "line 1: got '60.0 0.0 5.0 5.0'; expected 2 or 4 or 6 or 7 numbers "
         "separated by ',', ';' or tabs, not spaces"),
        ("60,0;0,0;5,0;5,0", "line 1, column 1: got '60,0'; expected a finite number with a "
         "decimal point, not a comma"),
        ("6_0,0,5,5", "line 1, column 1: got '6_0'; expected a finite number without '_' "
         "(Python reads 6_0 as 60)"),
    ],
)  # fmt: skip
def test_rows_in_a_form_the_reader_does_not_take_are_named(tmp_path, row, says):
    from tinyrace.tracks.centerline_csv import read_loop

    (tmp_path / "c.csv").write_text(f"{row}\n" * 8)  # before: every line read as a header
    with pytest.raises(ConfigError) as caught:
        read_loop(tmp_path / "c.csv", "t", "k")
    assert str(caught.value.problems[0]).endswith(says)


def test_a_race_car_placed_on_a_cell_that_is_not_free_is_refused():
    race = {"num_agents": 2, "start": "poses", "poses": [[13.29, 0, 1.73], [0.0, 0.0, 0.0]]}
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment="f1tenth_loop", race=race)
    ((key, allowed),) = problems_of(caught)
    assert key == "race.poses[1]"
    assert "car 'car_1' would start on a cell of the map that is not free" in allowed
    assert "inside the track on the map's free cells" in allowed
