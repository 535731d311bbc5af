"""A car in a race sees the others (sensors/machinery/draw_cars.py): cameras draw their
footprints in their colours, the overviews and videos draw and name every car."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from tinyrace.cars.state import CarState, footprint_corners
from tinyrace.config import car_colors
from tinyrace.ground.texture import transform_points
from tinyrace.race import parallel_env
from tinyrace.sensors.machinery.draw_cars import CAR_LABEL, CarLooks, draw_names, draw_race
from tinyrace.sensors.machinery.pinhole import world_to_car
from tinyrace.world.snapshot import Snapshot

CAMERA = {"id": "camera", "resolution": [100, 100], "roi": [10, 10]}  # 10 px/m, 10 m ahead
PINHOLE = {"id": "pinhole", "type": "perspective_camera", "resolution": [60, 80]}
LABELS = {**PINHOLE, "id": "labels", "format": "classes"}


def ahead_of(pose, distance):
    x, y, heading = pose
    return (x + distance * math.cos(heading), y + distance * math.sin(heading), heading)


def race(num_agents, **kwargs):
    """A race on the circuit (metres) whose cars wear a birdseye and two pinhole cameras."""
    return parallel_env(
        environment="circuit",
        num_agents=num_agents,
        cameras=[CAMERA],
        sensors=[PINHOLE, LABELS],
        **kwargs,
    )


def placed(env, *gaps):
    """Observations with car 0 at its grid pose and car k ``gaps[k-1]`` metres ahead of
    car 0's front axle (rear axle to front axle: ``gap`` m of free road between them)."""
    env.reset(seed=0)
    first = env.core.snapshot().cars[0]
    length = first.footprint[0]
    poses = [first.pose] + [ahead_of(first.pose, length + gap) for gap in gaps]
    observations, infos = env.reset(seed=0, options={"poses": poses})
    return observations, infos, env.core.snapshot()


def is_color(image, color):
    return (image == np.asarray(color, np.uint8)).all(axis=-1)


def test_a_car_two_metres_ahead_shows_in_the_birdseye_camera_in_its_colour():
    env = race(2)
    observations, _, snapshot = placed(env, 2.0)
    image = observations["car_0"]["camera"]
    blue = car_colors(env.core.config)[1]
    camera = env.seats[0].sensors[0].camera(env.core.layout)
    first, other = snapshot.cars
    corners = transform_points(
        camera.matrix(first.front_axle, first.pose[2]), footprint_corners(other)
    )
    column, row = np.round(corners.mean(axis=0)).astype(int)
    assert tuple(image[row, column]) == blue  # the middle of its footprint
    length, width = other.footprint
    inside = is_color(image, blue).sum()
    assert 0.8 * length * width * 100 < inside <= 1.1 * length * width * 100  # 100 px per m^2
    rows = np.flatnonzero(is_color(image, blue).any(axis=1))
    assert 100 - rows.max() - 1 == pytest.approx(20, abs=1.5)  # 2 m from the bottom edge
    # the car behind sees nothing of the car ahead of it in its own camera
    assert not is_color(observations["car_1"]["camera"], car_colors(env.core.config)[0]).any()


def test_one_car_out_of_sight_leaves_the_picture_as_a_lone_cars():
    env = race(2)
    observations, _, snapshot = placed(env, -60.0)  # far behind: no camera looks there
    alone = race(1)
    alone.reset(seed=0)
    lone, _ = alone.reset(seed=0, options={"poses": [snapshot.cars[0].pose]})
    for key in ("camera", "pinhole", "labels"):
        assert np.array_equal(observations["car_0"][key], lone["car_0"][key]), key


def test_the_pinhole_cameras_see_the_car_ahead_on_the_ground():
    env = race(2)
    observations, infos, snapshot = placed(env, 2.0)
    camera = env.seats[0].sensors[1]
    first, other = snapshot.cars
    to_car = world_to_car(first.front_axle, first.pose[2], False)
    middle = footprint_corners(other).mean(axis=0)
    ahead, right, _ = to_car @ (*middle, 1.0)
    column, row = np.round(camera.pinhole.project(np.array([[ahead, right, 0.0]]))[0]).astype(int)
    assert tuple(observations["car_0"]["pinhole"][row, column]) == car_colors(env.core.config)[1]
    assert observations["car_0"]["labels"][row, column] == CAR_LABEL
    assert infos["car_0"]["sensor_labels"]["labels"][CAR_LABEL] == "car"
    # behind the camera: nothing
    assert not (observations["car_1"]["labels"] == CAR_LABEL).any()


def test_a_car_alongside_is_cut_at_the_cameras_plane_and_seen_on_its_side():
    env = race(2)
    env.reset(seed=0)
    first = env.core.snapshot().cars[0]
    x, y, heading = first.pose
    left = (x - 1.8 * math.sin(heading), y + 1.8 * math.cos(heading), heading)  # 1.8 m left
    ahead = ahead_of(left, 2.0)  # its front axle 2 m past car 0's, where the camera sits
    observations, _ = env.reset(seed=0, options={"poses": [first.pose, ahead]})
    blue = is_color(observations["car_0"]["pinhole"], car_colors(env.core.config)[1])
    columns = np.flatnonzero(blue.any(axis=0))
    assert blue.sum() > 10 and columns.max() < 40  # in the left half of the 80 px image
    assert blue[:, 0].any()  # out past the left edge: the part beside and behind the camera


def test_a_gray_pinhole_camera_paints_the_car_in_its_colours_gray():
    gray = {**PINHOLE, "id": "gray", "format": "gray"}
    env = parallel_env(environment="circuit", num_agents=2, sensors=[PINHOLE, gray])
    observations, _, _ = placed(env, 2.0)
    blue = car_colors(env.core.config)[1]
    level = cv2.cvtColor(np.array([[blue]], np.uint8), cv2.COLOR_RGB2GRAY)[0, 0]
    where = is_color(observations["car_0"]["pinhole"], blue)
    assert where.sum() > 20
    assert (observations["car_0"]["gray"][where] == level).all()


def test_a_distorting_lens_sees_the_car_where_its_pixels_meet_the_ground():
    lens = {**PINHOLE, "intrinsics": [40, 40, 39.5, 29.5], "distortion": [0.2, 0.05, 0, 0, 0]}
    env = parallel_env(environment="circuit", num_agents=2, sensors=[lens])
    observations, _, snapshot = placed(env, 2.0)
    pinhole = next(s for s in env.seats[0].sensors if s.id == "pinhole").pinhole
    first, other = snapshot.cars
    to_car = world_to_car(first.front_axle, first.pose[2], False)
    quad = transform_points(to_car[:2], footprint_corners(other))
    ahead, right = pinhole.ground_points
    edges = [(quad[k], quad[(k + 1) % 4]) for k in range(4)]
    sides = [(b[0] - a[0]) * (right - a[1]) - (b[1] - a[1]) * (ahead - a[0]) for a, b in edges]
    # the pixels whose ground point lies in its footprint (on one side of all four edges)
    inside = np.all([side > 1e-6 for side in sides], axis=0) | np.all(
        [side < -1e-6 for side in sides], axis=0
    )
    inside[: pinhole.sky_rows] = False
    assert inside.sum() > 20
    blue = is_color(observations["car_0"]["pinhole"], car_colors(env.core.config)[1])
    assert (blue & ~inside).sum() <= 4
    assert (blue & inside).sum() >= inside.sum() - 4  # edge pixels may round either way


def test_a_car_is_painted_in_its_own_colour_whoever_looks():
    env = race(3)
    env.reset(seed=0)
    first = env.core.snapshot().cars[0]
    length = first.footprint[0]
    behind = ahead_of(first.pose, -(length + 2.0))
    far = ahead_of(first.pose, 80.0)
    observations, _ = env.reset(seed=0, options={"poses": [first.pose, far, behind]})
    red = car_colors(env.core.config)[0]
    assert is_color(observations["car_2"]["camera"], red).sum() > 100  # car 0, seen by car 2


def test_carracing_view_shows_the_car_ahead_in_its_colour():
    env = parallel_env(num_agents=2, render_mode="rgb_array")
    env.reset(seed=0)
    first = env.core.snapshot().cars[0]
    poses = [first.pose, ahead_of(first.pose, 12.0)]
    env.reset(seed=0, options={"poses": poses})
    for _ in range(50):  # CarRacing's view zooms in during the first second
        observations, *_ = env.step({agent: np.zeros(3, np.float32) for agent in env.agents})
    blue = car_colors(env.core.config)[1]
    assert is_color(observations["car_0"], blue).sum() > 10  # in the 96x96 observation
    assert is_color(env.render(), blue).sum() > 200  # and in the 600x400 video frame


# carolo_cup's grid holds 3 cars behind its spawn (a 4th would start off the picture)
@pytest.mark.parametrize(
    ("environment", "cars"), [("carolo_cup", 3), ("circuit", 4), ("f1tenth_loop", 4)]
)
def test_the_overview_draws_every_car_in_its_colour(environment, cars):
    env = parallel_env(environment=environment, num_agents=cars, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    colors = car_colors(env.core.config)
    for car, color in enumerate(colors):
        assert is_color(frame, color).sum() >= 4, (car, color)
    lone = parallel_env(environment=environment, num_agents=1, render_mode="rgb_array")
    lone.reset(seed=0)
    alone = lone.render()
    assert not any(is_color(alone, color).any() for color in colors[1:])


def test_names_are_written_beside_each_car_in_its_colour():
    car = CarState(
        model="test",
        pose=(10.0, 10.0, 0.0),
        velocity=(0.0, 0.0),
        speed=0.0,
        yaw_rate=0.0,
        steer=0.0,
        front_axle=(14.0, 10.0),
        rear_axle=(10.0, 10.0),
        footprint=(4.0, 2.0),
    )
    frame = np.zeros((200, 300, 3), np.uint8)
    looks = CarLooks(((204, 0, 0), (0, 114, 178)), ("car_0", "rival"))
    to_pixels = np.array([[5.0, 0, 0], [0, 5.0, 0]])
    snapshot = Snapshot(0.0, 0, (car,), order=(1,))  # this car is the world's car 1
    draw_names(frame, to_pixels, snapshot, looks)
    red, _, blue = (frame[..., c].astype(int) for c in range(3))
    bluish = (blue > 60) & (blue > red + 40)  # the text's antialiased strokes
    columns = np.flatnonzero(bluish.any(axis=0))
    assert bluish.sum() > 20 and columns.min() > 14 * 5  # right of the car's front (70 px)
    assert not ((red > 60) & (red > blue + 40)).any()  # car 0's colour is not this car's


def test_seen_from_keeps_each_cars_index_in_the_world():
    cars = tuple(
        CarState("test", (float(i), 0.0, 0.0), (0.0, 0.0), 0.0, 0.0, 0.0, (0.0, 0.0), (0.0, 0.0),
                 (1.0, 1.0))
        for i in range(4)
    )  # fmt: skip
    snapshot = Snapshot(0.0, 0, cars)
    seen = snapshot.seen_from(2)
    assert [car.pose[0] for car in seen.cars] == [2.0, 0.0, 1.0, 3.0]
    assert [seen.index(k) for k in range(4)] == [2, 0, 1, 3]
    again = seen.seen_from(3)  # the fourth of ``seen``: the world's car 3
    assert [again.index(k) for k in range(4)] == [3, 2, 0, 1]
    assert [snapshot.index(k) for k in range(4)] == [0, 1, 2, 3]


def test_a_car_gone_from_the_track_is_neither_drawn_nor_named():
    def parked(x: float) -> CarState:
        return CarState("test", (x, 10.0, 0.0), (0.0, 0.0), 0.0, 0.0, 0.0, (x + 4.0, 10.0),
                        (x, 10.0), (4.0, 2.0))  # fmt: skip

    looks = CarLooks(((204, 0, 0), (0, 114, 178)), ("car_0", "rival"))
    to_pixels = np.array([[5.0, 0, 0], [0, 5.0, 0]])
    racing = Snapshot(0.0, 0, (parked(2.0), parked(30.0)))
    drawn = np.zeros((200, 300, 3), np.uint8)
    draw_race(drawn, to_pixels, racing, looks)
    assert is_color(drawn, looks.colors[1]).sum() > 100  # its footprint, 20 x 10 px
    finished = Snapshot(0.0, 0, racing.cars, gone=frozenset({1}))
    frame = np.zeros((200, 300, 3), np.uint8)
    draw_race(frame, to_pixels, finished, looks)
    blue = frame[..., 2].astype(int) > frame[..., 0].astype(int) + 40
    assert not blue.any()  # no footprint, no name in its colour
    assert (frame[..., 0] > 60).any()  # car 0's name is still written
