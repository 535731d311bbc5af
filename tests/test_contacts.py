"""Contacts that mean contact: a touch is not a hit, an overlap of 1 mm is.

The F1TENTH single-track car (body 0.58 x 0.31 m, axles 0.33 m apart) in a world without
an env: cars nose to nose, tail to tail and side by side, and a car against a wall, each
placed exactly touching and then 1 mm deeper. The start checks (``placement_problems``,
``start_fits``) judge the body's footprint as the world does.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tinyrace.cars.single_track import SingleTrackCar
from tinyrace.cars.single_track_model import PRESETS
from tinyrace.episodes.start_pose import placement_problems, quad_size
from tinyrace.tracks.base import Track
from tinyrace.world.world import World

DT = 1 / 50  # [s]
F1TENTH = PRESETS["f1tenth"]
LENGTH, WIDTH = F1TENTH.length, F1TENTH.width  # [m] the body: 0.58 x 0.31
# [m] from the pose (centre of gravity) to the body's nose and tail
NOSE = F1TENTH.lf + (LENGTH - F1TENTH.wheelbase) / 2
TAIL = F1TENTH.lr + (LENGTH - F1TENTH.wheelbase) / 2
MM = 1e-3  # [m]


def world_with(poses: list[tuple[float, float, float]], walls: np.ndarray | None = None) -> World:
    world = World()
    if walls is not None:
        world.add_walls(walls)
    for pose in poses:
        world.add_car(SingleTrackCar.build(world.space, pose, F1TENTH))
    return world


def pair(case: str, overlap: float) -> list[tuple[float, float, float]]:
    """Two cars on the x axis placed ``overlap`` [m] into each other (0: touching)."""
    if case == "nose_to_nose":  # car 0 faces +x, car 1 faces -x
        return [(0.0, 0.0, 0.0), (2 * NOSE - overlap, 0.0, math.pi)]
    if case == "tail_to_tail":
        return [(0.0, 0.0, math.pi), (TAIL + TAIL - overlap, 0.0, 0.0)]
    if case == "nose_to_tail":
        return [(0.0, 0.0, 0.0), (NOSE + TAIL - overlap, 0.0, 0.0)]
    assert case == "side_by_side"
    return [(0.0, 0.0, 0.0), (0.0, WIDTH - overlap, 0.0)]


CASES = ["nose_to_nose", "tail_to_tail", "nose_to_tail", "side_by_side"]


def test_the_footprint_the_world_sees_is_the_whole_body():
    (quad,) = world_with([(1.0, 2.0, 0.3)]).footprints()
    assert quad_size(quad) == pytest.approx((LENGTH, WIDTH))
    assert quad.mean(axis=0) == pytest.approx(
        [1.0 + (NOSE - TAIL) / 2 * math.cos(0.3), 2.0 + (NOSE - TAIL) / 2 * math.sin(0.3)]
    )


@pytest.mark.parametrize("case", CASES)
def test_cars_that_only_touch_do_not_hit(case):
    world = world_with(pair(case, 0.0))
    contacts = world.look(DT)
    assert [c.cars for c in contacts] == [set(), set()]
    contacts = world.step(DT, [(0.0, 0.0), (0.0, 0.0)])
    assert [c.new_cars for c in contacts] == [[], []]


@pytest.mark.parametrize("case", CASES)
def test_cars_one_millimetre_into_each_other_hit(case):
    world = world_with(pair(case, MM))
    contacts = world.look(DT)
    assert [c.cars for c in contacts] == [{1}, {0}]
    assert [c.new_cars for c in contacts] == [[1], [0]]


def test_a_car_pulling_away_from_a_touch_drives_on_and_one_driving_in_is_stopped():
    world = world_with(pair("nose_to_tail", 0.0))  # car 1 just ahead of car 0
    world.look(DT)
    for _ in range(10):  # car 1 drives away; car 0 stands
        world.step(DT, [(0.0, 0.0), (0.0, 2.0)])
    assert world.states()[1].pose[0] > NOSE + TAIL + 0.05
    world = world_with(pair("nose_to_tail", 0.0))
    world.look(DT)
    contacts = world.step(DT, [(0.0, 2.0), (0.0, 0.0)])  # car 0 drives into car 1
    assert contacts[0].cars == {1}
    assert world.states()[0].pose[0] == 0.0 and world.states()[0].speed == 0.0  # put back


def wall_ahead(overlap: float) -> np.ndarray:
    """A wall box whose face is ``overlap`` [m] behind the nose of a car at the origin."""
    face = NOSE - overlap
    return np.array([[face, -1.0, face + 0.5, 1.0]])


def test_a_car_touching_a_wall_is_not_crashed_and_one_millimetre_in_is():
    touching = world_with([(0.0, 0.0, 0.0)], wall_ahead(0.0))
    [contacts] = touching.look(DT)
    assert contacts.walls == set()
    [contacts] = touching.step(DT, [(0.0, 0.0)])
    assert not contacts.crashed
    into = world_with([(0.0, 0.0, 0.0)], wall_ahead(MM))
    [contacts] = into.look(DT)
    assert contacts.walls == {0}
    [contacts] = into.step(DT, [(0.0, 0.0)])
    assert contacts.crashed


def _track(walls: np.ndarray) -> Track:
    return Track(
        kind="test",
        unit="m",
        metres_per_unit=1.0,
        y_down=False,
        bounds=(-10.0, -10.0, 10.0, 10.0),
        spawns=((0.0, 0.0, 0.0),),
        walls=walls,
    )


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize(("overlap", "refused"), [(0.0, False), (MM, True)])
def test_the_start_check_lets_touching_cars_start_and_refuses_overlapping_ones(
    case, overlap, refused
):
    world = world_with(pair(case, overlap))
    track = _track(np.zeros((0, 4)))
    problems = placement_problems(
        track, world.states(), ["a", "b"], "t.yaml", ["p0", "p1"], footprints=world.footprints()
    )
    assert [p.path for p in problems] == (["p1"] if refused else [])
    if refused:
        assert "on car 'a'" in problems[0].allowed
        assert f"{LENGTH:.2f} x {WIDTH:.2f}" in problems[0].allowed  # the body, not the axles


def test_a_body_over_a_wall_is_refused_though_its_axles_are_clear():
    """The wall's face 0.1 m behind the nose: the old axle-to-axle box (0.33 m) was clear of
    it, the body (0.58 m) is not."""
    walls = wall_ahead(0.1)
    assert walls[0, 0] > F1TENTH.lf  # clear of the front axle
    world = world_with([(0.0, 0.0, 0.0)])
    track = _track(walls)
    problems = placement_problems(
        track, world.states(), ["a"], "t.yaml", ["p0"], footprints=world.footprints()
    )
    assert len(problems) == 1 and "on a wall" in problems[0].allowed
    touching = placement_problems(
        _track(wall_ahead(0.0)), world.states(), ["a"], "t", ["p0"], footprints=world.footprints()
    )
    assert touching == []


def test_a_cone_touched_is_left_standing_and_one_millimetre_in_is_knocked():
    radius = 0.1  # [m]
    for overlap, knocked in ((0.0, set()), (MM, {0})):
        world = world_with([(0.0, 0.0, 0.0)])
        world.add_cones(np.array([[NOSE + radius - overlap, 0.0]]), np.array([radius]))
        [contacts] = world.look(DT)
        assert contacts.cones == knocked, overlap
