"""One step, owned once: the episode keeps the clock, the one step counter, every car's
score and carried reward, and judges every car; the envs above adapt its result, and the
vector stepper asks the car model for its tyre batch and Gymnasium only public things."""

from __future__ import annotations

import dataclasses
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.env import TinyRaceEnv
from tinyrace.episodes.referee import CarStep
from tinyrace.race import RaceEnv
from tinyrace.vector.batched import BatchStepper

GAS = np.array([0.0, 1.0, 0.0], np.float32)


def test_the_env_reads_the_episodes_one_counter_clock_and_score() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    core: Any = env.unwrapped
    assert (core.steps, core.t, core.score) == (0, 0.0, 0.0)  # before any reset
    env.reset(seed=0)
    episode = core.episode
    carried = core.score  # the reset's tiles, carried to the first step
    assert carried == sum(episode.carry[0].values()) > 0  # its spawn is on tiles
    total = carried
    assert core.steps == episode.steps == 0 and core.t == episode.t == core.dt
    for _ in range(30):
        _, reward, *_ = env.step(GAS)
        total += reward
    assert core.steps == episode.steps == 30
    assert core.t == pytest.approx(31 * core.dt)  # the reset's own step counted
    assert core.score == episode.scores[0] == pytest.approx(total - carried)  # paid once
    assert episode.carry[0] == {}  # paid by the first step
    env.close()


def test_a_race_step_is_one_episode_step_judging_every_car(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    env = RaceEnv(num_agents=3)
    env.reset(seed=1)
    episode = env.core.episode
    assert episode is not None
    judged: list[list[CarStep | None]] = []
    step = episode.step

    def counted() -> list[CarStep | None]:
        judged.append(step())
        return judged[-1]

    monkeypatch.setattr(episode, "step", counted)
    _, rewards, _, _, infos = env.step({agent: GAS for agent in env.agents})
    assert len(judged) == 1 and all(isinstance(car, CarStep) for car in judged[0])
    for i, agent in enumerate(env.possible_agents):
        car = judged[0][i]
        assert car is not None
        assert rewards[agent] == car.reward and infos[agent]["reward_terms"] == car.terms
    assert len(episode.scores) == 3 and episode.scores[0] == env.core.score
    env.close()


def test_a_parked_car_is_judged_no_more() -> None:
    env = RaceEnv(num_agents=2)
    env.reset(seed=2)
    episode = env.core.episode
    assert episode is not None
    episode.leave(1, "collision")
    env.agents = env.agents[:1]
    cars = episode.step()
    assert cars[0] is not None and cars[1] is None
    env.close()


def test_the_batch_is_a_capability_of_the_car_model(monkeypatch: pytest.MonkeyPatch) -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    assert BatchStepper.fits([env])
    course = env.unwrapped.course  # type: ignore[attr-defined]
    monkeypatch.setattr(course, "car_model", dataclasses.replace(course.car_model, batch=None))
    assert not BatchStepper.fits([env])  # same car, same actions: no batch offered
    env.close()


def test_a_time_limit_without_a_spec_is_not_batched() -> None:
    limited = gym.wrappers.TimeLimit(TinyRaceEnv(), 5)  # a bare env: no spec to read the limit from
    assert limited.spec is None and not BatchStepper.fits([limited])
    assert BatchStepper.fits([gym.make("tinyrace/CarRacing-v0", max_episode_steps=5)])
