"""The other cars' ranges on the lidar's two paths: the compiled kernel, which tests a car
only on the beams within the angle its footprint spans, gives the plain path's ranges bit
for bit; and the plain path gives ``ranges_to_cars``' ranges for the same beams."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tinyrace.sensors.kernels import other_cars as compiled
from tinyrace.sensors.lidar import beam_angles, directions
from tinyrace.sensors.machinery import other_cars

FANS = [(1, 270.0), (3, 2.0), (7, 90.0), (8, 30.0), (100, 359.0), (360, 360.0), (1080, 270.0)]

coordinate = st.floats(-12, 12)
car = st.tuples(
    coordinate, coordinate, st.floats(-60, 60), st.floats(0.3, 5), st.floats(0.2, 3)
)  # rear axle x, y [m], heading [rad] (many turns too), length, width [m]


@settings(max_examples=150, deadline=None)
@given(
    origin=st.tuples(coordinate, coordinate),
    heading=st.floats(-60, 60),
    cars=st.lists(car, min_size=1, max_size=7),
    fan_index=st.integers(0, len(FANS) - 1),
    y_down=st.booleans(),
    max_range=st.sampled_from([3.0, 10.0, 30.0]),
    seed=st.integers(0, 2**32 - 1),
)
# the lidar on a car's edge: a range of zero, +0.0 in both (the compiled max kept -0.0)
@example((1.0, 0.0), 0.0, [(0.0, 0.0, 0.0, 1.0, 1.0)], 0, False, 3.0, 0)
def test_the_compiled_path_gives_the_plain_ranges_bit_for_bit(
    origin, heading, cars, fan_index, y_down, max_range, seed
):
    beams, fov = FANS[fan_index]
    angles = beam_angles(beams, math.radians(fov))
    fan = other_cars.fan(angles)
    rows = np.array(cars, np.float64)
    walls = np.random.default_rng(seed).uniform(0, max_range, beams).astype(np.float32)
    walls[::3] = np.float32(max_range)  # beams that meet no wall
    plain = other_cars.add_cars(walls, origin, heading, y_down, fan, rows, max_range)
    fast = compiled.add_cars(walls, origin, heading, y_down, fan, rows, max_range)
    assert fast.dtype == plain.dtype == np.float32
    assert np.array_equal(fast.view(np.uint32), plain.view(np.uint32))


def test_cars_around_the_lidar_on_a_full_circle_and_a_car_around_the_lidar():
    """Cars at every side (behind the lidar too: the fan's wrap-round), one with the lidar
    inside it (every beam 0) and one beyond the range (no beam changes)."""
    angles = beam_angles(720, 2 * math.pi)
    fan = other_cars.fan(angles)
    assert fan.full
    ring = [(6 * math.cos(t), 6 * math.sin(t), t + 1.0, 1.0, 0.5) for t in np.linspace(0, 6, 9)]
    walls = np.full(720, np.float32(20.0))
    for y_down in (False, True):
        for heading in (0.0, 3.1, -7.0):
            rows = np.array(ring)
            plain = other_cars.add_cars(walls, (0.0, 0.0), heading, y_down, fan, rows, 20.0)
            fast = compiled.add_cars(walls, (0.0, 0.0), heading, y_down, fan, rows, 20.0)
            assert np.array_equal(fast, plain)
            assert (plain < 20.0).sum() > 9 * 4  # every car of the ring stops some beams
    around = np.array([[-1.0, -0.5, 0.3, 2.0, 1.0]])
    assert (compiled.add_cars(walls, (0.0, 0.0), 0.0, False, fan, around, 20.0) == 0).all()
    far = np.array([[25.0, 0.0, 0.0, 2.0, 1.0]])
    assert np.array_equal(compiled.add_cars(walls, (0.0, 0.0), 0.0, False, fan, far, 20.0), walls)


def test_the_plain_path_gives_ranges_to_cars_ranges():
    rng = np.random.default_rng(0)
    angles = beam_angles(270, math.radians(270))
    fan = other_cars.fan(angles)
    for _ in range(20):
        rows = np.column_stack(
            [rng.uniform(-8, 8, (4, 2)), rng.uniform(-4, 4, 4), rng.uniform(1, 4, 4),
             rng.uniform(0.5, 2, 4)]
        )  # fmt: skip
        heading, y_down = float(rng.uniform(-4, 4)), bool(rng.integers(2))
        c, s = math.cos(heading), math.sin(heading)
        beams = np.stack(other_cars.turned(fan.cos, fan.sin, c, s, y_down), axis=1)
        assert np.allclose(beams, directions(angles, heading, y_down), atol=1e-12)
        states = [_state(*row) for row in rows]
        walls = np.full(len(angles), np.float32(30.0))
        got = other_cars.add_cars(walls, (0.5, -0.5), heading, y_down, fan, rows, 30.0)
        assert np.array_equal(got, other_cars.ranges_to_cars((0.5, -0.5), beams, states, 30.0))


def _state(x: float, y: float, heading: float, length: float, width: float):
    from tinyrace.cars.state import CarState

    front = (x + length * math.cos(heading), y + length * math.sin(heading))
    return CarState("test", (x, y, heading), (0.0, 0.0), 0.0, 0.0, 0.0, front, (x, y),
                    (length, width))  # fmt: skip


@settings(max_examples=100, deadline=None)
@given(st.tuples(coordinate, coordinate), car)
def test_a_footprint_seen_from_the_origin_is_the_same_float64_on_both_paths(origin, car):
    assert compiled._box(*origin, *car) == other_cars.box(*origin, *car)
