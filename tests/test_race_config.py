"""The cars of a race as configured (race.cars, start, poses, laps) and bad input to races."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from pettingzoo.test import parallel_api_test, parallel_seed_test

from tests.test_race import TRACKS, footprints_overlap, make
from tinyrace.config import Color, car_colors, load_env_config, race_cars
from tinyrace.config.colors import palette_color
from tinyrace.drivers.centerline import CenterlineDriver, route_of
from tinyrace.errors import ConfigError
from tinyrace.race import parallel_env

TWO = [
    {"id": "red", "colour": [0, 0, 255]},  # [b, g, r]
    {"id": "blue", "colour": "#0000ff"},
]


def test_cars_take_their_ids_colours_and_knobs_laid_over_the_car_section():
    loaded = load_env_config(
        environment="circuit",
        overrides={
            "car": {"velocity": 12.0, "max_acceleration": 3.0},
            "race": {"cars": [TWO[0], {**TWO[1], "car": {"velocity": 8.0}}, {}]},
        },
    )
    cars = race_cars(loaded.config)
    assert loaded.config.race.num_agents == 3  # left out: the number of entries
    assert [car.id for car in cars] == ["red", "blue", "car_2"]
    assert car_colors(loaded.config) == [
        Color.rgb(255, 0, 0),
        Color.rgb(0, 0, 255),
        palette_color(2),
    ]
    assert [car.car.velocity for car in cars] == [12.0, 8.0, 12.0]
    assert {car.car.max_acceleration for car in cars} == {3.0}  # the shared knob
    assert {car.car.wheelbase for car in cars} == {2.5}  # the track kind's default (metres)


def test_num_agents_alone_names_the_cars_by_index_with_the_palette():
    loaded = load_env_config(environment="circuit", overrides={"race": {"num_agents": 3}})
    assert [car.id for car in race_cars(loaded.config)] == ["car_0", "car_1", "car_2"]
    assert car_colors(loaded.config) == [palette_color(i) for i in range(3)]


@pytest.mark.filterwarnings("ignore:.*ignores unknown options")
def test_cars_of_different_models_and_sensors_race_in_one_world_with_their_own_spaces():
    cars = [
        {"id": "throttle"},  # the track's default: kinematic_throttle
        {"id": "f1", "car": {"model": "single_track"}},
        {"id": "carracing", "car": {"model": "dynamic"}, "sensors": [{"type": "state", "id": "s"}]},
    ]
    env = parallel_env(environment="circuit", race={"cars": cars})
    assert env.possible_agents == ["throttle", "f1", "carracing"]
    assert env.action_space("throttle").shape == (2,)
    assert env.action_space("carracing").shape == (3,)  # steer, gas, brake
    assert env.action_space("f1") != env.action_space("throttle")  # [angle, speed]
    assert set(env.observation_space("carracing").spaces) == {"front", "s"}  # its own sensors
    assert set(env.observation_space("f1").spaces) == {"front"}  # the shared camera
    observations, _ = env.reset(seed=0)
    for agent in env.agents:
        assert observations[agent] in env.observation_space(agent)
    models = [type(car).__name__ for car in env.core.world.cars]
    assert models == ["KinematicThrottleCar", "SingleTrackCar", "DynamicCar"]
    parallel_api_test(parallel_env(environment="circuit", race={"cars": cars}), num_cycles=10)


@pytest.mark.parametrize("kind", sorted(TRACKS))
@pytest.mark.parametrize("start", ["grid", "random"])
def test_named_cars_start_apart_on_every_track_kind(kind, start):
    own = {"id": "c", "colour": "#123456", "sensors": [{"type": "state", "id": "s"}]}
    race = {"cars": [{"id": "a"}, {"id": "b"}, own], "start": start}
    env = make(kind, race=race)
    observations, infos = env.reset(seed=3)
    assert list(observations) == ["a", "b", "c"] and infos["c"]["id"] == "c"
    assert env.observation_space("c") != env.observation_space("a")  # its own sensors
    assert "s" in env.observation_space("c").spaces
    for agent in env.agents:
        assert observations[agent] in env.observation_space(agent)
    assert car_colors(env.core.config)[2] == Color.rgb(0x12, 0x34, 0x56)
    cars = env.core.snapshot().cars
    assert not any(footprints_overlap(cars[i], cars[j]) for i in range(3) for j in range(i))
    _, _, _, _, infos = env.step({a: env.action_space(a).sample() for a in env.agents})
    assert set(infos) == {"a", "b", "c"}
    again = make(kind, race=race)
    again.reset(seed=3)
    assert [car.pose for car in again.core.snapshot().cars] == [car.pose for car in cars]


def test_a_random_start_is_seeded_and_places_cars_along_the_line():
    env = parallel_env(environment="circuit", race={"num_agents": 4, "start": "random"})
    env.reset(seed=1)
    first = [car.pose for car in env.core.snapshot().cars]
    env.reset(seed=2)
    second = [car.pose for car in env.core.snapshot().cars]
    assert first != second
    line = env.core.layout.centerline
    length, width = env.core.snapshot().cars[0].footprint
    for x, y, _ in first:  # the pose is the car's middle, on the road beside the line
        assert np.hypot(line[:, 0] - x, line[:, 1] - y).min() <= 0.6 * width + 0.5 * length


@pytest.mark.filterwarnings("ignore:.*ignores unknown options")
def test_a_race_of_named_cars_with_a_random_start_passes_pettingzoo_seed_test():
    race = {"cars": [{"id": "a"}, {"id": "b", "car": {"model": "single_track"}}], "start": "random"}
    parallel_seed_test(lambda: parallel_env(environment="f1tenth_loop", race=race), num_cycles=10)


def test_poses_from_the_config_place_the_cars():
    env = parallel_env(environment="circuit", num_agents=2)
    env.reset(seed=0)
    grid = [list(car.pose) for car in env.core.snapshot().cars]
    poses = grid[::-1]
    placed = parallel_env(
        environment="circuit", race={"num_agents": 2, "start": "poses", "poses": poses}
    )
    placed.reset(seed=0)
    got = [car.pose for car in placed.core.snapshot().cars]
    assert np.allclose(got, poses)


# -- laps -----------------------------------------------------------------------------------
def test_lap_times_and_the_best_lap_of_cars_driven_round_two_laps():
    """Both cars follow the centreline for two laps; the lap times are the steps between
    the tiles starting again, times dt; the first car home is first and leaves the track,
    so the other finishes its laps behind it. With ``tile_reward: first`` the leader is paid
    for the tiles of each lap, the follower for none of them."""
    race = {"laps": 2, "tile_reward": "first"}
    env = parallel_env(environment="f1tenth_loop", num_agents=2, race=race)
    _, infos = env.reset(seed=0)
    drivers = {}
    for agent, seat in zip(env.possible_agents, env.seats, strict=True):
        drivers[agent] = CenterlineDriver()
        drivers[agent].follow(
            route_of(env.core), seat.actions.space, env.core.dt, seat.actions.kind
        )
    steps, new_lap_at, last, final = 0, [], 0, {}
    paid = {"car_0": [0.0, 0.0], "car_1": [0.0, 0.0]}  # tile reward per lap
    while env.agents and steps < 3000:
        actions = {agent: drivers[agent].act(None, infos[agent]) for agent in env.agents}
        _, _, terminations, _, infos = env.step(actions)
        steps += 1
        final.update(infos)
        for agent, agent_info in infos.items():
            lap = min(len(agent_info["lap_times"]), 1)
            paid[agent][lap] += agent_info["reward_terms"].get("tiles", 0.0)
        info = infos.get("car_0")
        if info is None:
            continue
        if info["tiles_visited"] < last:  # the tiles start again: a lap is over
            new_lap_at.append(steps)
            assert info["lap_times"] == [pytest.approx(steps * env.core.dt)]
            assert info["best_lap"] == info["lap_times"][0]
            assert terminations["car_0"] is False  # one lap of two: the car races on
        last = info["tiles_visited"]
        if terminations["car_0"]:
            finished_at = steps
    assert env.agents == [] and len(new_lap_at) == 1
    first, second = final["car_0"]["lap_times"]
    assert final["car_0"]["termination"] == final["car_1"]["termination"] == "lap_finished"
    assert first == pytest.approx(new_lap_at[0] * env.core.dt)
    assert second == pytest.approx((finished_at - new_lap_at[0]) * env.core.dt)
    assert final["car_0"]["best_lap"] == min(first, second)
    assert len(final["car_1"]["lap_times"]) == 2
    assert sum(final["car_1"]["lap_times"]) > sum(final["car_0"]["lap_times"])
    assert final["car_0"]["position"] == 1 and final["car_1"]["position"] == 2
    assert env.core.world.gone == {0, 1}  # both taken off the track at the line
    assert paid["car_0"][0] > 900 and paid["car_0"][1] > 900  # 1000 per lap
    # the follower: only the few tiles between its grid place and the pole's (about 5 of 245)
    assert paid["car_1"][0] < 30 and paid["car_1"][1] < 30


def test_the_race_ends_at_the_step_limit_for_every_car():
    env = parallel_env(environment="f1tenth_loop", num_agents=3, sim={"step_limit": 4})
    env.reset(seed=0)
    for _ in range(4):
        _, _, terminations, truncations, _ = env.step(
            {a: env.action_space(a).sample() * 0 for a in env.agents}
        )
    assert truncations == {"car_0": True, "car_1": True, "car_2": True}
    assert not any(terminations.values()) and env.agents == []


# -- bad input ------------------------------------------------------------------------------
def problems(**overrides) -> str:
    with pytest.raises(ConfigError) as error:
        parallel_env(**overrides)
    return str(error.value)


def test_duplicate_ids_are_refused_naming_the_car():
    text = problems(environment="circuit", race={"cars": [{"id": "x"}, {}, {"id": "x"}]})
    assert "race.cars[2].id: got 'x'; expected a unique car id; car 0 is called 'x' too" in text
    text = problems(environment="circuit", race={"cars": [{}, {"id": "car_0"}]})
    assert "race.cars[1].id" in text


def test_more_cars_than_entries_or_sixteen_are_refused():
    text = problems(environment="circuit", race={"num_agents": 3, "cars": TWO})
    assert "race.num_agents: got 3; expected 2: race.cars lists 2 cars" in text
    text = problems(environment="circuit", race={"cars": [{}] * 17})
    assert "race.cars: got '17 cars'; expected at most 16 cars" in text


def test_more_cars_than_room_on_the_grid_or_the_line_are_refused_naming_the_car():
    # the grid follows the drawn line round the picture: columns 20 car widths aside leave it
    text = problems(environment="carolo_cup", num_agents=3, race={"grid_offset": 20})
    assert "race.num_agents" in text and "car 'car_2' would start outside the track" in text
    text = problems(
        environment="f1tenth_loop",
        race={"cars": [{}, {}, {"id": "last"}], "start": "random", "grid_spacing": 100},
    )
    assert "race.cars[2]" in text and "reference line" in text


def test_overlapping_poses_are_refused_naming_the_car_in_the_config_and_at_reset():
    env = parallel_env(environment="circuit", race={"cars": TWO})
    env.reset(seed=0)
    pole = list(env.core.snapshot().cars[0].pose)
    beside = [pole[0] + 0.3, pole[1], pole[2]]
    text = problems(
        environment="circuit", race={"cars": TWO, "start": "poses", "poses": [pole, beside]}
    )
    assert "race.poses[1]" in text and "car 'blue' would start on car 'red'" in text
    with pytest.raises(
        ConfigError, match=r"<reset options>: poses\[1\].*car 'blue' would start on car 'red'"
    ):
        env.reset(seed=0, options={"poses": [pole, beside]})
    env.reset(seed=0)  # the env resets as before


def test_a_pose_on_a_wall_or_outside_the_track_is_refused():
    env = parallel_env(environment="f1tenth_loop", num_agents=2)
    env.reset(seed=0)
    pole = env.core.snapshot().cars[0].pose
    _, _, x1, y1 = env.core.layout.bounds
    with pytest.raises(ConfigError, match=r"poses\[1\].*car 'car_1' would start outside"):
        env.reset(seed=0, options={"poses": [pole, (x1 + 5.0, y1 + 5.0, 0.0)]})
    x, y = env.core.layout.wall_quads[0].mean(axis=0)  # a wall's middle
    on_wall = (float(x), float(y), 0.0)
    with pytest.raises(ConfigError, match=r"poses\[1\].*car 'car_1' would start .*on a wall"):
        env.reset(seed=0, options={"poses": [pole, on_wall]})


def test_poses_in_the_config_must_be_one_per_car_and_only_with_start_poses():
    text = problems(
        environment="circuit", race={"cars": TWO, "start": "poses", "poses": [[0, 0, 0]]}
    )
    assert "race.poses" in text and "one pose per car (2 cars); no pose for blue" in text
    text = problems(environment="circuit", race={"cars": TWO, "poses": [[0, 0, 0], [9, 9, 0]]})
    assert "poses are read with start: poses only" in text


def test_a_bad_knob_or_model_of_one_car_is_named_at_its_entry():
    text = problems(environment="circuit", race={"cars": [{}, {"car": {"model": "kinematic"}}]})
    assert "race.cars[1].car.model: got 'kinematic'" in text
    text = problems(environment="circuit", race={"cars": [{}, {"car": {"wheelbase": -1}}]})
    assert "race.cars[1].car.wheelbase: got -1" in text
    text = problems(environment="circuit", car={"wheelbase": -1}, race={"cars": TWO})
    assert "car.wheelbase: got -1" in text and "race.cars" not in text  # once, where it is
    text = problems(
        environment="circuit",
        race={"cars": [{}, {"sensors": [{"type": "cones", "id": "c"}]}]},
    )
    assert "race.cars[1].sensors[0].type" in text


def test_an_unknown_opponent_driver_is_named_by_its_index():
    with pytest.raises(
        ConfigError, match=r"opponents\[2\]\.driver: .*unknown opponent driver 'nobody'"
    ):
        gym.make(
            "tinyrace/TinyRace-v0",
            environment="circuit",
            opponents=[{}, {"driver": "centerline"}, {"driver": "nobody"}],
        )


def test_opponents_of_their_own_model_follow_the_line():
    """A single-track rival among kinematic cars follows the line with its own steering and
    size (with the learner's car's route it leaves the road at once: 2 tiles in 300 steps)."""
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment="circuit",
        race={"cars": [{}, {"id": "rival", "car": {"model": "single_track"}}]},
        opponents=[{"driver": "centerline"}],
    )
    env.reset(seed=0)
    grid = [car.pose for car in env.unwrapped.snapshot().cars]
    env.reset(seed=0, options={"poses": grid[::-1]})  # the rival on the pole, ahead
    idle = np.zeros(env.action_space.shape, np.float32)
    for _ in range(300):
        _, _, _, _, info = env.step(idle)
    assert env.unwrapped.episode.progress(1) > 20  # 2 m tiles: over 40 m along the line
    assert 1 not in env.unwrapped.world.parked
    assert info["lap_times"] == [] and info["best_lap"] is None and info["position"] == 2


def test_a_car_taken_off_the_track_is_neither_met_nor_seen():
    """Car 1 stands 2 m ahead of car 0: car 0's forward beam stops there until car 1 is
    taken off the track (as after its last lap); then the beam goes on, as without it."""
    sensors = [{"id": "lidar", "type": "lidar", "beams": 3, "fov": 2.0}]
    env = parallel_env(environment="circuit", num_agents=3, sensors=sensors)
    env.reset(seed=0)
    cars = env.core.snapshot().cars
    x, y, heading = cars[0].pose
    ahead = cars[0].footprint[0] + 2.0
    front = (x + ahead * math.cos(heading), y + ahead * math.sin(heading), heading)
    observations, _ = env.reset(seed=0, options={"poses": [cars[0].pose, front, cars[2].pose]})
    assert observations["car_0"]["lidar"][1] == pytest.approx(2.0, abs=1e-4)
    env.core.episode.leave(1, "lap_finished")
    snapshot = env.core.snapshot()
    assert snapshot.gone == {1} and snapshot.seen_from(2).gone == {2}
    assert env._observe(snapshot, 0)["lidar"][1] > 2.0
    assert env.core.world.counts[0] == 2  # its body is out of the space
