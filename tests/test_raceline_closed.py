"""Racelines as F1TENTH ships them: ``;``-separated, the last row repeating the first.

The closing copy is dropped; any other repeat is refused on the line that repeats, and a
second closing copy on the last line (not on the first).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from tinyrace.errors import ConfigError
from tinyrace.tracks.centerline_csv import read_loop

DATA = Path(__file__).parent / "data" / "f1tenth_example"
RACELINE_HEADER = "# a\n# b\n# s_m; x_m; y_m; psi_rad; kappa_radpm; vx_mps; ax_mps2\n"


def raceline(points: np.ndarray) -> str:
    rows = [f"{i * 0.1:.4f}; {x:.6f}; {y:.6f}; 0; 0; 6; 0" for i, (x, y) in enumerate(points)]
    return RACELINE_HEADER + "\n".join(rows) + "\n"


def circle(count: int) -> np.ndarray:
    t = np.linspace(0, 2 * math.pi, count, endpoint=False)
    return np.column_stack((10 * np.cos(t), 5 * np.sin(t)))


def test_f1tenth_example_waypoints_as_shipped_load_without_the_closing_copy():
    path = DATA / "example_waypoints.csv"
    rows = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    first, last = rows[0].split(";"), rows[-1].split(";")
    assert first[1:3] == last[1:3]  # the file as shipped closes its loop on the first point
    loop = read_loop(path, "t", "k")
    assert len(loop.points) == len(rows) - 1
    assert loop.points[0].tolist() == [float(first[1]), float(first[2])]
    assert int(loop.table.lines[-1]) == 3 + len(rows) - 1  # the last line kept: the one before


def test_a_closing_copy_is_dropped_and_the_rest_kept(tmp_path):
    points = circle(40)
    path = tmp_path / "closed.csv"
    path.write_text(raceline(np.vstack((points, points[:1]))))
    loop = read_loop(path, "t", "k")
    assert np.allclose(loop.points, points, atol=1e-6)
    assert len(loop.table.values) == len(points)


def test_a_repeat_inside_the_file_names_its_own_line(tmp_path):
    points = circle(40)
    doubled = np.vstack((points[:10], points[9:10], points[10:]))  # row 11 repeats row 10
    path = tmp_path / "repeat.csv"
    path.write_text(raceline(doubled))
    with pytest.raises(ConfigError) as error:
        read_loop(path, "t", "k")
    (problem,) = error.value.problems
    assert problem.source == str(path)
    assert problem.path == "line 14"  # 3 comment lines, then the 11th row
    assert "line 13" in problem.allowed  # the one it repeats


def test_two_closing_copies_blame_the_last_line_not_the_first(tmp_path):
    points = circle(40)
    path = tmp_path / "twice.csv"
    path.write_text(raceline(np.vstack((points, points[:1], points[:1]))))
    with pytest.raises(ConfigError) as error:
        read_loop(path, "t", "k")
    (problem,) = error.value.problems
    assert problem.path == f"line {3 + 41}"  # the first copy, now the loop's last point
    assert "line 4" in problem.allowed and "first" in problem.allowed


def test_a_loop_that_only_closes_on_itself_is_still_too_short(tmp_path):
    points = circle(4)[:3]
    path = tmp_path / "short.csv"
    path.write_text(raceline(np.vstack((points, points[:1]))))
    with pytest.raises(ConfigError) as error:
        read_loop(path, "t", "k")
    assert "at least 4" in str(error.value)
