"""Lookahead core: points and curvature along a circle and a straight line."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tinyrace.sensors.lookahead import ReferenceLine, lookahead

R = 40.0  # [u] circle radius


def _circle(n: int = 300) -> np.ndarray:
    a = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.stack([R * np.cos(a), R * np.sin(a)], axis=1)


@pytest.mark.parametrize("y_down", [False, True])
def test_points_ahead_on_a_circle_and_its_curvature(y_down):
    spacing, count = 3.0, 10
    line = ReferenceLine.build(_circle(), closed=True, spacing=spacing, y_down=y_down)
    pose = (R, 0.0, math.pi / 2)  # on the circle, along it (angle grows)
    index = line.nearest(R, 0.0, None)
    rows = lookahead(line, index, pose, y_down, count)
    assert abs(line.spacing - spacing) < 1e-3 * spacing  # rounded to whole grid steps
    s = line.spacing * np.arange(1, count + 1)
    turn = -1.0 if y_down else 1.0  # growing angle is clockwise on a y-down picture: right
    expected_x = R * np.sin(s / R)
    expected_y = turn * R * (1 - np.cos(s / R))
    assert rows.dtype == np.float32 and rows.shape == (count, 3)
    # the polyline's chords sit up to R (1 - cos(pi/300)) = 0.002 u inside the circle
    np.testing.assert_allclose(rows[:, 0], expected_x, atol=spacing / 16 + 0.01)
    np.testing.assert_allclose(rows[:, 1], expected_y, atol=0.05)
    np.testing.assert_allclose(rows[:, 2], turn / R, rtol=0.02)  # chords of a 300-gon


def test_search_near_the_last_match_follows_the_car():
    line = ReferenceLine.build(_circle(), closed=True, spacing=2.0, y_down=False)
    first = line.nearest(R, 0.0, None)
    for a in (0.03, 0.3, 2.0):  # within the window, and far beyond it
        moved = line.nearest(R * math.cos(a), R * math.sin(a), first)
        assert moved == line.nearest(R * math.cos(a), R * math.sin(a), None) != first


def test_open_line_stops_at_its_end_and_is_straight():
    line = ReferenceLine.build(np.array([[0.0, 0.0], [10.0, 0.0]]), False, 2.0, y_down=False)
    rows = lookahead(line, line.nearest(4.0, 1.0, None), (4.0, 1.0, 0.0), False, 5)
    np.testing.assert_allclose(rows[:, 0], [2, 4, 6, 6, 6], atol=1e-6)
    np.testing.assert_allclose(rows[:, 1], -1.0, atol=1e-6)  # the line is 1 u to the right
    np.testing.assert_allclose(rows[:, 2], 0.0, atol=1e-9)
