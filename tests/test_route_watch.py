"""What a run measures along the track's reference line: the distance to it and the laps
driven round it (tinyrace.experiment.route)."""

from __future__ import annotations

import math

import numpy as np

from tinyrace.experiment.route import RouteWatch


def circle(n: int = 120, radius: float = 50.0) -> np.ndarray:
    angles = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    return np.stack([radius * np.cos(angles), radius * np.sin(angles)], axis=1)


def drive(watch: RouteWatch, angles: np.ndarray, radius: float = 52.0) -> list[int]:
    return [watch.laps(radius * math.cos(a), radius * math.sin(a)) for a in angles]


def test_the_distance_is_to_the_nearest_point_of_the_line():
    square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    closed, open_line = RouteWatch(square, closed=True), RouteWatch(square, closed=False)
    assert closed.distance(5.0, 3.0) == 3.0  # to the bottom edge
    assert closed.distance(-2.0, 5.0) == 2.0  # to the closing edge, (0, 10) -> (0, 0)
    assert open_line.distance(-2.0, 5.0) == math.hypot(2.0, 5.0)  # no closing edge: to a corner
    assert math.isclose(closed.distance(13.0, 14.0), 5.0)  # past a corner


def test_laps_are_whole_rounds_driven_forward():
    watch = RouteWatch(circle(), closed=True)
    angles = np.linspace(0.0, 2.5 * 2 * math.pi, 1000)  # 2.5 rounds in small steps
    laps = drive(watch, angles)
    assert laps[-1] == 2
    first = laps.index(1)
    assert abs(angles[first] - 2 * math.pi) < 2 * math.pi / 120 + 1e-9  # within a point


def test_driving_backwards_or_to_and_fro_finishes_no_lap():
    backwards = RouteWatch(circle(), closed=True)
    assert drive(backwards, np.linspace(0.0, -3 * 2 * math.pi, 1500))[-1] == 0
    wobble = RouteWatch(circle(), closed=True)
    angles = 0.8 * np.sin(np.linspace(0.0, 40.0, 2000))  # [rad] back and forth round 0
    assert max(drive(wobble, angles)) == 0


def test_an_open_line_has_no_laps():
    watch = RouteWatch(circle()[:60], closed=False)
    assert max(drive(watch, np.linspace(0.0, 4 * math.pi, 500))) == 0
