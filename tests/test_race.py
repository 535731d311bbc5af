"""Several cars on one track: the PettingZoo ParallelEnv (tinyrace.race)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

from tinyrace.cars.state import CarState, footprint_corners
from tinyrace.errors import ConfigError
from tinyrace.race import aec_env, parallel_env

# one shipped track of every kind (procedural: no environment)
TRACKS = {
    "procedural": None,
    "image": "carolo_cup",
    "centerline": "circuit",
    "cone_map": "autocross",
    "ros_map": "f1tenth_loop",
}


def footprints_overlap(a: CarState, b: CarState) -> bool:
    """Whether two cars' footprints (convex quads) overlap: no separating axis among their
    edges' normals."""
    quads = footprint_corners(a), footprint_corners(b)
    for quad in quads:
        for k in range(4):
            edge = quad[(k + 1) % 4] - quad[k]
            normal = np.array([-edge[1], edge[0]])
            pa, pb = quads[0] @ normal, quads[1] @ normal
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def make(kind: str, **kwargs):
    environment = TRACKS[kind]
    extra = {} if environment is None else {"environment": environment}
    return parallel_env(**extra, **kwargs)


@pytest.mark.filterwarnings("ignore:.*ignores unknown options")
@pytest.mark.parametrize("kind", sorted(TRACKS))
def test_pettingzoo_api_and_seed_tests_pass_on_every_track_kind(kind):
    parallel_api_test(make(kind, num_agents=3), num_cycles=20)
    parallel_seed_test(lambda: make(kind, num_agents=3), num_cycles=10)


@pytest.mark.filterwarnings("ignore:.*ignores unknown options")
def test_the_aec_form_passes_pettingzoo_api_test():
    api_test(aec_env(environment="f1tenth_loop", num_agents=2), num_cycles=20)


@pytest.mark.parametrize("kind", sorted(TRACKS))
def test_the_grid_puts_every_car_apart_with_the_pole_at_the_spawn(kind):
    alone = make(kind, num_agents=1)
    _, infos = alone.reset(seed=4)
    count = 3 if kind == "image" else 8  # carolo_cup's straight grid leaves the image at 4
    env = make(kind, num_agents=count)
    _, grid = env.reset(seed=4)
    assert len(grid) == count
    state = env.state()
    cars = env.core.snapshot().cars
    for i in range(count):
        for j in range(i + 1, count):
            assert not footprints_overlap(cars[i], cars[j]), (i, j, state[i], state[j])
    # the pole is the single car's spawn, moved sideways by the grid's offset only
    (x0, y0, h0), (x1, y1, h1) = infos["car_0"]["pose"], grid["car_0"]["pose"]
    assert h1 == pytest.approx(h0)
    along = (x1 - x0) * math.cos(h0) + (y1 - y0) * math.sin(h0)
    assert along == pytest.approx(0.0, abs=1e-6)


def test_cars_that_drive_into_each_other_say_whom_they_hit_and_stop():
    env = parallel_env(environment="f1tenth_loop", num_agents=2)
    env.reset(seed=0)
    x, y, heading = env.core.snapshot().cars[0].pose
    length = env.core.snapshot().cars[0].footprint[0]
    ahead = (math.cos(heading), math.sin(heading))
    gap = 3.0 * length
    poses = [
        (x, y, heading),
        (x + gap * ahead[0], y + gap * ahead[1], heading + math.pi),  # nose to nose
    ]
    env.reset(seed=0, options={"poses": poses})
    full = {agent: np.array([0.0, 1.0], dtype=np.float32) for agent in env.agents}
    hits = []
    for _ in range(200):
        _, _, _, _, infos = env.step({a: full[a] for a in env.agents})
        hits += [(a, tuple(info["cars_hit"])) for a, info in infos.items() if info["cars_hit"]]
        if hits:
            break
    assert sorted(hits) == [("car_0", ("car_1",)), ("car_1", ("car_0",))]
    cars = env.core.snapshot().cars
    assert cars[0].speed == cars[1].speed == 0.0  # both stopped where they stood


def test_a_tile_pays_only_the_first_car_with_tile_reward_first():
    def tiles_paid(tile_reward: str) -> list[float]:
        env = parallel_env(num_agents=2, race={"tile_reward": tile_reward})
        env.reset(seed=2)
        gas = np.array([0.0, 0.6, 0.0], dtype=np.float32)
        paid = [0.0, 0.0]
        for _ in range(120):
            _, _, _, _, infos = env.step({a: gas for a in env.agents})
            for info in infos.values():
                paid[info["car"]] += info["reward_terms"].get("tiles", 0.0)
        return paid

    own, first = tiles_paid("own"), tiles_paid("first")
    assert own[0] > 0 and own[1] > 0  # both cars drive over tiles
    assert first[0] == own[0]  # the leader visits every tile first
    assert first[1] < own[1]  # the follower finds most of its tiles paid already


def test_a_car_whose_episode_ends_leaves_the_race_parked_and_the_others_go_on():
    # a track without a map: a start on a cell that is not free (the map's edge) is refused
    env = parallel_env(environment="autocross", num_agents=2)
    env.reset(seed=0)
    _, y0, x1, y1 = env.core.layout.bounds
    cars = env.core.snapshot().cars
    leaving = (x1 - 0.3, (y0 + y1) / 2, 0.0)  # at the right edge, facing out
    env.reset(seed=0, options={"poses": [cars[0].pose, leaving]})
    gas = np.array([0.0, 1.0], dtype=np.float32)
    for _ in range(100):
        _, _, terminations, _, infos = env.step({a: gas for a in env.agents})
        if terminations.get("car_1"):
            break
    assert terminations == {"car_0": False, "car_1": True}
    assert infos["car_1"]["termination"] == "out_of_bounds"
    assert env.agents == ["car_0"]
    parked = env.core.snapshot().cars[1].pose
    for _ in range(5):
        observations, _, _, _, _ = env.step({"car_0": gas})
        assert list(observations) == ["car_0"]
    assert env.core.snapshot().cars[1].pose == parked  # it stands where it left the race


@pytest.mark.parametrize(
    ("setup", "first", "second", "extra"),
    [
        ({"environment": "f1tenth_loop", "num_agents": 2}, "car_0", "car_1", "car_7"),
        ({"environment": "circuit", "race": {"cars": [{"id": "red"}, {"id": "blue"}]}},
         "red", "blue", "car_1"),  # cars named by id: car_1 is no car's name
    ],
    ids=["numbered", "named"],
)  # fmt: skip
def test_actions_for_missing_or_extra_cars_are_refused_naming_them(setup, first, second, extra):
    env = parallel_env(**setup)
    env.reset(seed=0)
    gas = np.array([0.0, 1.0], dtype=np.float32)
    with pytest.raises(ConfigError, match=rf"<step actions>: {second}: .*no action for this car"):
        env.step({first: gas})
    agents = f"{first}, {second}"
    with pytest.raises(ConfigError, match=rf"{extra}: .*no such car; the agents are {agents}"):
        env.step({first: gas, second: gas, extra: gas})


def test_more_than_sixteen_cars_is_a_clear_error():
    with pytest.raises(ConfigError, match=r"race\.num_agents"):
        parallel_env(num_agents=17)


def test_poses_of_the_wrong_shape_are_refused():
    env = parallel_env(environment="f1tenth_loop", num_agents=2)
    with pytest.raises(ConfigError, match=r"poses.*2 finite"):
        env.reset(seed=0, options={"poses": [(0.0, 0.0, 0.0)]})


def test_every_car_observes_from_its_own_seat():
    env = parallel_env(
        environment="f1tenth_loop",
        num_agents=2,
        sensors=[{"type": "lidar", "id": "lidar"}],
    )
    observations, _ = env.reset(seed=0)
    assert set(observations) == {"car_0", "car_1"}
    assert not np.array_equal(observations["car_0"]["lidar"], observations["car_1"]["lidar"])


def test_a_learner_races_opponents_driven_by_the_centreline_driver():
    import gymnasium as gym

    alone = gym.make("tinyrace/TinyRace-v0", environment="circuit")
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment="circuit",
        opponents=[{"driver": "centerline", "speed": 0.8}, {"driver": "centerline"}],
    )
    assert env.observation_space == alone.observation_space
    assert env.action_space == alone.action_space
    observation, info = env.reset(seed=0)
    assert info["position"] == 1 and info["cars_hit"] == []
    core = env.unwrapped
    start = [car.pose for car in core.snapshot().cars]
    assert len(start) == 3
    idle = np.zeros(env.action_space.shape, dtype=np.float32)
    for _ in range(150):
        observation, _, _, _, info = env.step(idle)
        assert observation in env.observation_space
    cars = core.snapshot().cars
    moved = [math.dist(cars[i].pose[:2], start[i][:2]) for i in range(3)]
    assert moved[0] < 1.0 < moved[1] < moved[2]  # the learner idled; 0.8 of the speed is slower
    assert core.episode.progress(2) > core.episode.progress(1) > 0
    assert info["position"] == 3  # both opponents are further on


def test_a_bad_opponent_is_named():
    import gymnasium as gym

    with pytest.raises(ConfigError, match=r"opponents\[1\].*unknown opponent driver 'fast'"):
        gym.make("tinyrace/TinyRace-v0", environment="circuit", opponents=[{}, {"driver": "fast"}])
    with pytest.raises(ConfigError, match=r"opponents\[0\].*speed"):
        gym.make("tinyrace/TinyRace-v0", environment="circuit", opponents=[{"speed": -1}])


def test_opponents_drive_the_single_track_car_through_its_own_actions():
    import gymnasium as gym

    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment="f1tenth_loop",
        car={"model": "single_track", "preset": "f1tenth"},
        opponents=[{"driver": "centerline"}],
    )
    env.reset(seed=0)
    grid = [car.pose for car in env.unwrapped.snapshot().cars]
    env.reset(seed=0, options={"poses": grid[::-1]})  # the opponent on the pole, ahead
    start = env.unwrapped.snapshot().cars[1].pose
    stay = np.array([0.0, 0.0], dtype=np.float32)  # [steering angle, speed]: the learner waits
    for _ in range(100):
        env.step(stay)
    assert env.unwrapped.episode.progress(1) > 0  # the opponent drives on
    assert math.dist(env.unwrapped.snapshot().cars[1].pose[:2], start[:2]) > 1.0


def test_a_lidar_sees_the_other_cars():
    """Car 1 stands 2 m ahead of car 0's front axle: car 0's forward beam stops there, and
    car 1's lidar (riding on car 1) does not see itself."""
    sensors = [{"id": "lidar", "type": "lidar", "beams": 3, "fov": 2.0}]  # middle beam ahead
    env = parallel_env(environment="circuit", num_agents=2, sensors=sensors)
    env.reset(seed=0)
    car = env.core.snapshot().cars[0]
    x, y, heading = car.pose
    ahead = car.footprint[0] + 2.0  # [m] from car 0's rear axle to car 1's
    behind_pose = (x, y, heading)
    front_pose = (x + ahead * math.cos(heading), y + ahead * math.sin(heading), heading)
    observations, _ = env.reset(seed=0, options={"poses": [behind_pose, front_pose]})
    assert observations["car_0"]["lidar"][1] == pytest.approx(2.0, abs=1e-4)
    assert observations["car_1"]["lidar"][1] > 2.0  # nothing of car 1 in its own beams
    alone = parallel_env(environment="circuit", num_agents=1, sensors=sensors)
    seen, _ = alone.reset(seed=0)
    assert seen["car_0"]["lidar"][1] > 2.0  # without car 1 the beam goes on
