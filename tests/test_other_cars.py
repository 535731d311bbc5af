"""Beams against other cars' footprints (sensors/machinery/other_cars.py) against an exact
segment-by-segment intersection."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from tinyrace.cars.state import CarState, footprint_corners
from tinyrace.sensors.machinery.other_cars import ranges_to_cars


def car_at(x: float, y: float, heading: float, length: float, width: float) -> CarState:
    front = (x + length * math.cos(heading), y + length * math.sin(heading))
    return CarState(
        model="test",
        pose=(x, y, heading),
        velocity=(0.0, 0.0),
        speed=0.0,
        yaw_rate=0.0,
        steer=0.0,
        front_axle=front,
        rear_axle=(x, y),
        footprint=(length, width),
    )


def cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def edge_distance(point: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from ``point`` to the segment a-b (the origin on an edge is either side)."""
    t = np.clip((point - a) @ (b - a) / max((b - a) @ (b - a), 1e-12), 0.0, 1.0)
    return float(np.hypot(*(a + t * (b - a) - point)))


def exact(
    origin: np.ndarray, beam: np.ndarray, corners: np.ndarray, far: float, grazing: float = 1e-12
) -> float:
    """The nearest crossing of the ray with the quad's four edges (0 inside), else ``far``;
    a ray within ``grazing`` of an edge's end counts as crossing it (a negative value: not)."""
    best = far
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        edge = b - a
        denominator = beam[0] * edge[1] - beam[1] * edge[0]
        if abs(denominator) < 1e-12:
            continue
        diff = a - origin
        t = (diff[0] * edge[1] - diff[1] * edge[0]) / denominator
        u = (diff[0] * beam[1] - diff[1] * beam[0]) / denominator
        if t >= 0 and -grazing <= u <= 1 + grazing:
            best = min(best, t)
    return best


@settings(max_examples=200, deadline=None)
@given(
    st.floats(-10, 10), st.floats(-10, 10), st.floats(-math.pi, math.pi),
    st.floats(0.5, 5), st.floats(0.3, 3),
)  # fmt: skip
@example(0.0, -1.0, -3.1415926535897927, 1.0, 1.0)  # a beam on the car's rear edge's line
def test_ranges_to_a_car_equal_the_exact_crossing(x, y, heading, length, width):
    car = car_at(x, y, heading, length, width)
    corners = footprint_corners(car)
    origin = np.array([0.0, 0.0])
    assume(min(edge_distance(origin, corners[k], corners[(k + 1) % 4]) for k in range(4)) > 1e-3)
    sides = [cross(corners[(k + 1) % 4] - corners[k], origin - corners[k]) for k in range(4)]
    inside = all(side > 0 for side in sides) or all(side < 0 for side in sides)
    angles = np.linspace(-math.pi, math.pi, 361)
    beams = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    got = ranges_to_cars((0.0, 0.0), beams, [car], 30.0)
    for beam, value in zip(beams, got, strict=True):
        # a beam that grazes a corner (within rounding) may hit or miss: either is right
        wants = [0.0] if inside else [exact(origin, beam, corners, 30.0, g) for g in (1e-9, -1e-9)]
        along = _along_an_edge(origin, beam, corners)
        if along is not None and along[0] - 1e-4 <= value <= along[1] + 1e-4:
            continue  # a beam on an edge's line (within rounding) meets it anywhere along it
        assert any(abs(value - want) <= 1e-4 * max(1.0, want) for want in wants), (beam, value)


def _along_an_edge(
    origin: np.ndarray, beam: np.ndarray, corners: np.ndarray
) -> tuple[float, float] | None:
    """(nearest, farthest) [units] along ``beam`` of an edge the beam runs on (parallel and
    within 1e-9 of its line), else None."""
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        edge = b - a
        length = float(np.hypot(*edge))
        if abs(cross(beam, edge)) < 1e-9 * length and abs(cross(edge, a - origin)) < 1e-9 * length:
            ends = sorted(((a - origin) @ beam, (b - origin) @ beam))
            if ends[1] >= 0:
                return max(ends[0], 0.0), ends[1]
    return None
