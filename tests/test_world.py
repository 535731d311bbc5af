"""The physics world without an env: controls and a time step in, contacts and snapshots out."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tinyrace.cars.dynamic import DynamicCar
from tinyrace.cars.kinematic_throttle import KinematicThrottleCar
from tinyrace.world.world import World

DT = 1 / 50  # [s]
GAS = (0.0, 1.0, 0.0)  # steer, gas, brake
ROAD = np.array([[(-100.0, -100.0), (100.0, -100.0), (100.0, 100.0), (-100.0, 100.0)]])


def dynamic_world(grass_off_tiles: bool, road: bool) -> World:
    """A CarRacing car at the origin, nose along +y, on one big road tile or on none."""
    world = World(grass_off_tiles=grass_off_tiles)
    if road:
        world.add_tiles(ROAD)
    world.add_car(DynamicCar.build(world.space, (0.0, 0.0, math.pi / 2)))
    return world


def speed_after(world: World, steps: int) -> float:
    world.look(DT)  # the contacts of the spawn
    for _ in range(steps):
        world.step(DT, [GAS])
    return world.snapshot(steps * DT, steps).car.speed


def test_wheels_on_a_tile_report_it_and_grip_as_on_road():
    world = dynamic_world(grass_off_tiles=True, road=True)
    [contacts] = world.look(DT)
    assert contacts.new_tile_touches == [0, 0, 0, 0]  # each wheel began touching tile 0
    assert all(tiles == {0} for tiles in contacts.wheel_tiles)
    assert world.step(DT, [GAS])[0].new_tile_touches == []  # refilled every step


def test_a_wheel_off_the_tiles_grips_as_on_grass_only_where_the_world_says_so():
    on_road = speed_after(dynamic_world(grass_off_tiles=True, road=True), 40)
    on_grass = speed_after(dynamic_world(grass_off_tiles=True, road=False), 40)
    grip_everywhere = speed_after(dynamic_world(grass_off_tiles=False, road=False), 40)
    assert on_grass < 0.9 * on_road  # wheelspin capped at 0.6 of the road's grip
    assert grip_everywhere == on_road


def test_a_snapshot_is_a_copy_that_later_steps_leave_alone():
    world = dynamic_world(grass_off_tiles=True, road=True)
    for _ in range(20):
        world.step(DT, [(0.5, 1.0, 0.0)])
    snapshot = world.snapshot(20 * DT, 20)
    car = world.cars[0]
    assert snapshot.car.pose == car.pose and snapshot.car.speed == car.speed
    assert snapshot.car.hull_angle == car.body.angle
    assert [w.omega for w in snapshot.car.wheels] == [w.omega for w in car.wheels]
    world.step(DT, [GAS])
    assert world.snapshot(21 * DT, 21).car.pose != snapshot.car.pose
    with pytest.raises(AttributeError):  # read-only
        snapshot.car.speed = 0.0  # type: ignore[misc]


def test_skid_marks_are_seen_read_only():
    world = dynamic_world(grass_off_tiles=True, road=True)
    for _ in range(30):
        world.step(DT, [(1.0, 1.0, 0.0)])  # full gas from standstill: the rear wheels spin
    skids = world.snapshot(0.6, 30).car.skids
    assert skids is not None and skids.lengths.any()
    with pytest.raises(ValueError):
        skids.points[0, 0] = (0.0, 0.0)


def test_looking_steps_the_contacts_but_does_not_drive():
    world = dynamic_world(grass_off_tiles=True, road=True)
    world.control(GAS)
    world.look(DT)
    assert world.snapshot(DT, 0).car.speed == 0.0


def test_a_wall_puts_the_car_back_and_stops_it():
    world = World()
    world.add_walls(np.array([[3.0, -5.0, 4.0, 5.0]]))  # [m] across the way ahead
    car = KinematicThrottleCar.build(
        world.space, (0.0, 0.0, 0.0), (2.0, 1.0), (10.0, 5.0, 5.0), (30.0, None)
    )
    world.add_car(car)
    for step in range(200):
        before = world.snapshot(step * DT, step).car.pose
        [contacts] = world.step(DT, [(0.0, 1.0)])
        if contacts.crashed:
            break
    else:
        pytest.fail("the car never reached the wall")
    after = world.snapshot(0.0, 0).car
    assert after.pose == before and after.speed == 0.0 and car.body.velocity == (0.0, 0.0)
    assert 0.5 < after.pose[0] <= 1.0  # its front stopped short of the wall at x = 3


def kinematic_car(world: World, pose: tuple[float, float, float]) -> KinematicThrottleCar:
    """A 2 m x 1 m car with throttle, taken into ``world``."""
    car = KinematicThrottleCar.build(world.space, pose, (2.0, 1.0), (10.0, 5.0, 5.0), (30.0, None))
    world.add_car(car)
    return car


def test_four_cars_driven_into_each_other_collide_and_each_reports_whom_it_touched():
    """Cars 0 and 1 drive head on along y = 0; car 2 drives into a wall far away; car 3
    stands still far away. Each car's contacts are its own."""
    world = World()
    world.add_walls(np.array([[40.0, 20.0, 41.0, 30.0]]))  # [m] in car 2's way
    cars = [
        kinematic_car(world, (-6.0, 0.0, 0.0)),  # rear axle at x = -6, nose toward +x
        kinematic_car(world, (6.0, 0.0, math.pi)),  # nose toward -x
        kinematic_car(world, (30.0, 25.0, 0.0)),
        kinematic_car(world, (-30.0, -30.0, 0.0)),
    ]
    gas, idle = (0.0, 1.0), (0.0, 0.0)
    met, crashed = [], []
    for step in range(150):
        contacts = world.step(DT, [gas, gas, gas, idle])
        met += [(step, i, other) for i, c in enumerate(contacts) for other in c.new_cars]
        crashed += [i for i, c in enumerate(contacts) if c.crashed]
    first = min(step for step, _, _ in met)
    assert {(i, other) for step, i, other in met if step == first} == {(0, 1), (1, 0)}
    assert {i for _, i, _ in met} == {0, 1}  # who hit whom: only the two, each reports the other
    assert set(crashed) == {2}  # the wall stopped car 2 alone
    states = world.states()
    front_0, front_1 = states[0].pose[0] + 2.0, states[1].pose[0] - 2.0
    assert front_0 < front_1 < front_0 + 1.0  # stopped nose to nose, never through each other
    assert states[0].speed == states[1].speed == 0.0  # each stopped where it stood
    assert states[3].pose == (-30.0, -30.0, 0.0) and cars[3].body.velocity == (0.0, 0.0)
    assert len(world.contacts) == 4 and world.contacts[2].cars == set()


def test_of_two_cars_nose_to_tail_the_one_pulling_away_drives_on():
    """A quick car 1 catches a slow car 0 from behind and keeps pushing: the car pulling
    away drives on at its own pace, the one running into it is put back at every touch
    (both stood there for good before: each was put back whenever they touched)."""
    world = World()
    slow = KinematicThrottleCar.build(
        world.space, (0.0, 0.0, 0.0), (2.0, 1.0), (4.0, 2.0, 5.0), (30.0, None)
    )
    world.add_car(slow)
    quick = KinematicThrottleCar.build(
        world.space, (-2.5, 0.0, 0.0), (2.0, 1.0), (10.0, 20.0, 5.0), (30.0, None)
    )
    world.add_car(quick)
    gas = (0.0, 1.0)
    touches = 0
    for _ in range(150):  # 3 s: car 0 alone would reach 4 m/s and 8 m
        contacts = world.step(DT, [gas, gas])
        touches += bool(contacts[1].new_cars)
        assert not contacts[0].crashed and not contacts[1].crashed  # cars are no walls
    states = world.states()
    assert touches >= 2  # car 1 caught up more than once
    assert states[0].pose[0] > 7.0 and states[0].speed > 3.5  # car 0 drove on, unhindered
    assert states[1].pose[0] + 2.0 <= states[0].pose[0] + 1e-9  # car 1 never went through it
    assert states[1].pose[0] > 3.0  # and it follows, stopping only at each touch


def test_a_world_holds_at_most_sixteen_cars():
    world = World()
    for i in range(16):
        assert kinematic_car(world, (10.0 * i, 0.0, 0.0)) is world.cars[i]
    with pytest.raises(ValueError, match="at most 16 cars"):
        kinematic_car(world, (500.0, 0.0, 0.0))
