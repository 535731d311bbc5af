"""First contact, fifth round: what a newcomer's mixed races and the racing docs found.

A race of mixed car models drives each car with its own model's actions (a driver sees its
own car).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from tinyrace.drivers import CenterlineDriver
from tinyrace.race import parallel_env
from tinyrace.race.drive import drive_race

KINEMATIC = {"model": "kinematic_throttle"}
SINGLE_TRACK = {"model": "single_track"}


class CarStates:
    """A race observer keeping every car's speed [m/s] and front-wheel angle [rad] per step."""

    def __init__(self, race: Any):
        self.race = race
        self.speeds: dict[str, list[float]] = {a: [] for a in race.possible_agents}
        self.wheels: dict[str, list[float]] = {a: [] for a in race.possible_agents}

    def start(self, observations: dict[str, Any], infos: dict[str, Any]) -> None:
        """The reset: nothing driven yet."""

    def step(self, actions: Any, *results: Any) -> None:
        cars = self.race.core.snapshot().cars
        for i, agent in enumerate(self.race.possible_agents):
            self.speeds[agent].append(cars[i].speed)
            self.wheels[agent].append(abs(cars[i].steer))


@pytest.mark.parametrize("shared, own", [(KINEMATIC, SINGLE_TRACK), (SINGLE_TRACK, KINEMATIC)])
def test_a_mixed_race_drives_each_car_with_its_own_models_actions(shared, own):
    race = parallel_env(
        environment="f1tenth_loop",
        car=shared,
        race={"cars": [{"id": "first"}, {"id": "second", "car": own}]},
    )
    states = CarStates(race)
    drivers = {agent: CenterlineDriver() for agent in race.possible_agents}
    drive_race(race, drivers, seed=0, max_steps=400, observer=states)
    core = race.core
    for i, (agent, car) in enumerate(zip(race.possible_agents, (shared, own), strict=True)):
        if car["model"] == "single_track":  # a throttle (-1..1) read as a speed [m/s]: < 1
            assert max(states.speeds[agent]) > 2.0, agent
        else:  # a wheel angle [rad] read as a steering action (-1..1): 42 % of the lock
            lock = core.course.racers[i].model.describe(core.car_config(i)).steer_lock
            assert max(states.wheels[agent]) > 0.9 * lock, agent
    race.close()


class Looker:
    """A driver that keeps what its ``reset(env)`` saw of its car (it is never asked to act)."""

    def reset(self, env: Any) -> None:
        view = env.unwrapped
        self.seen = (view.config.car.model, view.action_spec.kind, view.car.pose)

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        raise AssertionError("max_steps=0: no step")


def test_a_drivers_view_of_a_race_is_its_own_cars():
    race = parallel_env(
        environment="f1tenth_loop",
        car=KINEMATIC,
        race={"cars": [{"id": "first"}, {"id": "second", "car": SINGLE_TRACK}]},
    )
    drivers = {agent: Looker() for agent in race.possible_agents}
    drive_race(race, drivers, seed=0, max_steps=0)
    poses = [car.pose for car in race.core.snapshot().cars]
    assert drivers["first"].seen == ("kinematic_throttle", "steer_throttle", poses[0])
    assert drivers["second"].seen == ("single_track", "angle_speed", poses[1])
    race.close()


def test_reset_places_every_car_first_and_the_trace_ranks_the_grid(tmp_path):
    """As docs/racing.md says: ``info["position"]`` shares a place between cars level on
    tiles (all 1 at reset); a run's trace gives each car a place of its own (the grid's)."""
    import csv

    from tinyrace import cli

    race = parallel_env(environment="f1tenth_loop", num_agents=3)
    _, infos = race.reset(seed=0)
    assert {agent: info["position"] for agent, info in infos.items()} == dict.fromkeys(
        race.possible_agents, 1
    )
    race.close()
    path = tmp_path / "race.yaml"
    path.write_text(
        "env: {environment: f1tenth_loop, race: {num_agents: 3}}\n"
        "driver: centerline\nepisodes: 1\nmax_steps: 3\n"
    )
    assert cli.main(["run", str(path), "--no-video", "-o", str(tmp_path / "runs")]) == 0
    (folder,) = (tmp_path / "runs").iterdir()
    first = {}
    for agent in ("car_0", "car_1", "car_2"):
        with (folder / f"episode_000_{agent}_trace.csv").open() as handle:
            first[agent] = int(next(csv.DictReader(handle))["position"])
    assert first == {"car_0": 1, "car_1": 2, "car_2": 3}  # the pole, then the grid behind


def test_two_numbers_of_cars_that_differ_are_refused_naming_both():
    import gymnasium as gym

    from tinyrace.errors import ConfigError

    with pytest.raises(ConfigError) as caught:
        parallel_env(environment="f1tenth_loop", num_agents=2, race={"num_agents": 3})
    (problem,) = caught.value.problems
    assert (problem.path, problem.value) == ("race.num_agents", 3)
    assert "num_agents=2 asks for 2 cars" in problem.allowed
    with pytest.raises(ConfigError, match=r"race.num_agents: got 3; .*opponents"):
        gym.make(
            "tinyrace/TinyRace-v0",
            environment="f1tenth_loop",
            opponents=[{"driver": "centerline"}],
            race={"num_agents": 3},
        )
    with pytest.raises(ConfigError, match=r"race: got 'x'; expected a mapping"):
        parallel_env(environment="f1tenth_loop", num_agents=2, race="x")


@pytest.mark.parametrize(
    ("keyword", "own"), [(3, 3), (3, 3.0), (np.int64(3), 3), (3, np.int64(3)), (3.0, np.int32(3))]
)
def test_the_same_number_of_cars_twice_is_taken(keyword, own):
    """The same number in two types (a float 3.0, numpy's integers) is the same number: each
    alone is taken as 3 cars, so both together are too."""
    race = parallel_env(environment="f1tenth_loop", num_agents=keyword, race={"num_agents": own})
    assert race.possible_agents == ["car_0", "car_1", "car_2"]
    race.close()


def test_numpy_numbers_are_numbers_to_the_config():
    import gymnasium as gym

    car = {"model": "single_track", "substeps": np.int64(4), "kinematic_below": np.float32(0.5)}
    env = gym.make("tinyrace/TinyRace-v0", environment="circuit", car=car)
    assert (env.unwrapped.config.car.substeps, env.unwrapped.config.car.kinematic_below) == (4, 0.5)
    assert type(env.unwrapped.config.car.substeps) is int
    env.close()


def test_the_centerline_drivers_knobs_are_documented_with_their_defaults():
    import inspect
    import re
    from pathlib import Path

    page = (Path(__file__).parents[1] / "docs" / "experiments.md").read_text()
    rows = dict(re.findall(r"^\| `(\w+)` \| ([-\d.]+) \|", page, flags=re.MULTILINE))
    defaults = {
        name: parameter.default
        for name, parameter in inspect.signature(CenterlineDriver).parameters.items()
    }
    assert {name: float(value) for name, value in rows.items()} == defaults


def test_a_top_speed_in_u_per_s_is_scaled_by_the_cars_wheelbase():
    """f1tenth_race's comment: top_speed 42 u/s is 4.3 m/s on the 0.33 m F1TENTH car."""
    race = parallel_env(environment="f1tenth_loop", num_agents=1)
    race.reset(seed=0)
    driver = CenterlineDriver(top_speed=42.0)
    driver.reset(race.core)
    assert race.core.car_facts.length == pytest.approx(0.33)
    assert max(driver.target_speeds) == pytest.approx(42.0 * 0.33 / 3.24)  # [m/s]
    assert round(max(driver.target_speeds), 1) == 4.3
    race.close()
