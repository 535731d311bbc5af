"""A grid that follows the track: places laid back along the reference line behind the
pole, in two staggered columns, each clear of walls, cones, obstacle colours and the
other cars, inside the track.

Over every shipped track (4 cars; 8 on tracks in metres), every spawn: the env checks each
spawn's grid when it is made, so making it is the test that every grid starts; the poses of
the first reset are then checked here against the reference line and each other.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from tinyrace.episodes.start import grid_places, grid_poses, line_length
from tinyrace.episodes.start_pose import grid_check, quads_overlap
from tinyrace.errors import ConfigError
from tinyrace.examples import track_names
from tinyrace.race import parallel_env
from tinyrace.tracks.base import Track

METRE_TRACKS = {"autocross", "circuit", "f1tenth_loop"}


def counts() -> list[tuple[str, int]]:
    return [(name, n) for name in track_names() for n in ((4, 8) if name in METRE_TRACKS else (4,))]


def test_the_shipped_tracks_are_the_ones_this_test_knows():
    assert set(track_names()) > METRE_TRACKS  # a renamed metre track would skip its 8 cars


def reference_points(track: Track) -> np.ndarray:
    """The reference line as points at most 1/20 of its spacing apart (the centreline
    densified), or a drawn trajectory's pixels."""
    if track.centerline is None:
        assert track.trajectory_points is not None
        return np.asarray(track.trajectory_points, np.float64)
    loop = np.asarray(track.centerline, np.float64)
    t = np.linspace(0.0, 1.0, 20, endpoint=False)[:, None, None]
    return (loop + t * (np.roll(loop, -1, axis=0) - loop)).reshape(-1, 2)


@pytest.mark.parametrize(("name", "count"), counts())
def test_a_full_grid_starts_on_every_shipped_track_along_its_line(name, count):
    env = parallel_env(environment=name, num_agents=count)  # every spawn's grid is checked
    env.reset(seed=0)
    core = env.core
    track, world = core.layout, core.world
    assert len(env.agents) == count
    cars = world.states()
    quads = world.footprints()
    x0, y0, x1, y1 = track.bounds
    line = reference_points(track)
    length, width = core.course.car_size(core.episode.draw)
    race = core.config.race
    side = race.grid_offset * width  # [track units] each column beside the line
    pole = cars[0].pose
    for i, (car, quad) in enumerate(zip(cars, quads, strict=True)):
        assert ((quad >= (x0, y0)) & (quad <= (x1, y1))).all(), f"car {i} outside the track"
        assert not any(quads_overlap(quad, quads[j]) for j in range(i)), f"car {i} on another"
        x, y, _ = car.pose
        near = np.hypot(line[:, 0] - x, line[:, 1] - y).min()
        # beside the line, by its column's offset (a drawn line's pixels: a few px more)
        assert near <= side + 0.05 * width + 3 * (track.unit == "px"), (i, near)
        if i:  # behind the pole, facing the way the track runs there
            assert math.hypot(x - pole[0], y - pole[1]) >= 0.9 * race.grid_spacing * length
    facts = [info for info in env.reset(seed=0)[1].values()]
    assert all(not f.get("cars_hit") for f in facts)


@pytest.mark.parametrize(("name", "count"), counts())
def test_the_cars_alternate_sides_of_the_line(name, count):
    env = parallel_env(environment=name, num_agents=count)
    env.reset(seed=0)
    core = env.core
    draw = core.episode.draw
    size = core.course.car_size(draw)
    race = core.config.race
    places = grid_places(draw.track, draw.spawn, 3 * count, size, race.grid_spacing, 0.0)
    poses = [car.pose for car in core.world.states()]
    sides = []
    for x, y, _ in poses:  # each car's side of the place on the line it stands beside
        nearest = min(places, key=lambda p: math.hypot(p[0] - x, p[1] - y))
        px, py, heading = nearest
        sides.append(
            math.copysign(1.0, -math.sin(heading) * (x - px) + math.cos(heading) * (y - py))
        )
    # places alternate sides; a skipped place may put two cars of one side in a row
    assert sides.count(1.0) >= 1 and sides.count(-1.0) >= 1
    assert sum(a != b for a, b in itertools.pairwise(sides)) >= (count - 1) // 2


def test_a_place_that_does_not_fit_is_left_empty_and_the_next_one_taken():
    env = parallel_env(environment="circuit", num_agents=1)
    env.reset(seed=0)
    track = env.core.layout
    spawn = track.spawns[0]
    size = (4.0, 2.0)
    places = grid_places(track, spawn, 9, size, 2.5, 0.6)
    taken = grid_poses(track, spawn, 4, size, 2.5, 0.6, lambda k, pose: pose != places[2])
    assert taken == [places[0], places[1], places[3], places[4]]
    none_fit = grid_poses(track, spawn, 3, size, 2.5, 0.6, lambda k, pose: k == 0)
    assert none_fit == [places[0], places[1], places[2]]  # unchecked: the start check names them


def test_the_grid_check_refuses_walls_and_other_cars_and_takes_what_fits():
    env = parallel_env(environment="f1tenth_loop", num_agents=2)
    env.reset(seed=0)
    core = env.core
    track = core.layout
    cars = [(racer.model, racer.car.car) for racer in core.course.racers]
    fits = grid_check(track, cars)
    pole = core.world.states()[0].pose
    assert fits(0, pole)
    assert not fits(1, pole)  # on the pole's car
    wall = track.wall_quads[0].mean(axis=0)
    assert not fits(1, (float(wall[0]), float(wall[1]), 0.0))
    x0, y0, _, _ = track.bounds
    assert not fits(1, (x0, y0, 0.0))  # half outside the map
    behind = core.world.states()[1].pose
    assert fits(1, behind)
    assert not fits(1, behind)  # taken now


def test_formula_student_races_four_cars_inside_its_picture():
    env = parallel_env(environment="formula_student", num_agents=4)
    observations, _ = env.reset(seed=1)
    assert len(observations) == 4
    for _ in range(5):
        env.step({agent: env.action_space(agent).sample() * 0 for agent in env.agents})


def test_a_grid_longer_than_the_reference_line_is_refused_at_grid_spacing():
    """No place wraps round the loop onto the cars ahead of it."""
    with pytest.raises(ConfigError, match=r"race\.grid_spacing: got 1000000000.0.*long"):
        parallel_env(environment="circuit", num_agents=3, race={"grid_spacing": 1e9})
    env = parallel_env(environment="circuit", num_agents=1)
    env.reset(seed=0)
    track = env.core.layout
    loop = line_length(track.centerline)
    size = (loop / 3.5, 2.0)  # [m] 4 places fit on the line, not 5
    places = grid_places(track, track.spawns[0], 5, size, 1.0, 0.0)
    taken = grid_poses(track, track.spawns[0], 4, size, 1.0, 0.0, lambda k, p: p != places[1])
    assert taken == [places[0], places[2], places[3], places[1]]  # not place 4: past the end
    with pytest.raises(ValueError, match="long"):
        grid_poses(track, track.spawns[0], 5, size, 1.0, 0.0)
