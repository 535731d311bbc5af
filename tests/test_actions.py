"""Action spaces and their checking, as CarRacing-v3 (point 7)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.error import InvalidAction

import tinyrace  # noqa: F401

PROCEDURAL_IDS = ["tinyrace/CarRacing-v0", "tinyrace/TinyRace-v0"]


@pytest.mark.parametrize("env_id", PROCEDURAL_IDS)
def test_continuous_space(env_id: str) -> None:
    space = gym.make(env_id).action_space
    assert space == spaces.Box(
        np.array([-1, 0, 0], np.float32), np.array([1, 1, 1], np.float32), dtype=np.float32
    )


def test_discrete_space() -> None:
    assert gym.make("tinyrace/CarRacing-v0", continuous=False).action_space == spaces.Discrete(5)
    env = gym.make("tinyrace/TinyRace-v0", config={"car": {"actions": "discrete"}})
    assert env.action_space == spaces.Discrete(5)


def run_discrete(first: int, then: int, seed: int = 0) -> list[dict]:
    """Infos of 40 steps of ``first`` followed by 30 of ``then`` (discrete actions)."""
    env = gym.make("tinyrace/CarRacing-v0", continuous=False)
    env.reset(seed=seed)
    return [env.step(first if i < 40 else then)[4] for i in range(70)]


def test_discrete_gas_accelerates_and_nothing_does_not() -> None:
    gas, idle = run_discrete(3, 3), run_discrete(0, 0)
    assert gas[-1]["speed"] > 20 and gas[-1]["speed"] > gas[39]["speed"]
    assert idle[-1]["speed"] < 1e-6


def test_discrete_brake_slows_down() -> None:
    braked, coasted = run_discrete(3, 4), run_discrete(3, 0)
    assert braked[-1]["speed"] < 0.5 * coasted[-1]["speed"]


@pytest.mark.parametrize(("action", "sign"), [(1, -1), (2, 1)])  # 1 right, 2 left
def test_discrete_steering_turns_the_right_way(action: int, sign: int) -> None:
    infos = run_discrete(3, action)
    turned = infos[-1]["pose"][2] - infos[39]["pose"][2]  # [rad] counter-clockwise
    assert sign * turned > 0.3


def test_continuous_steer_plus_one_turns_right() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    env.reset(seed=0)
    for _ in range(40):
        _, _, _, _, before = env.step(np.array([0.0, 1.0, 0.0], np.float32))
    for _ in range(20):
        _, _, _, _, after = env.step(np.array([1.0, 0.0, 0.0], np.float32))
    assert after["pose"][2] - before["pose"][2] < -0.3


@pytest.mark.parametrize(
    "action", [3, np.int64(3), np.int32(3), np.uint8(3), np.array(3), np.array(3, np.int16)]
)
def test_python_and_numpy_integers_are_the_same_action(action) -> None:
    reference = run_discrete(3, 3)[-1]
    env = gym.make("tinyrace/CarRacing-v0", continuous=False)
    env.reset(seed=0)
    for _ in range(70):
        _, _, _, _, info = env.step(action)
    assert info == reference


@pytest.mark.parametrize(
    "action", [[0.2, 0.5, 0.0], (0.2, 0.5, 0.0), np.array([0.2, 0.5, 0.0]), np.array([0, 1, 0])]
)
def test_continuous_accepts_any_real_array_like(action) -> None:
    expected = np.asarray(action, np.float32)
    a, b = gym.make("tinyrace/CarRacing-v0"), gym.make("tinyrace/CarRacing-v0")
    a.reset(seed=0)
    b.reset(seed=0)
    for _ in range(10):
        step_a, step_b = a.step(action), b.step(expected)
    np.testing.assert_array_equal(step_a[0], step_b[0])
    assert step_a[4] == step_b[4]


CONTINUOUS_INVALID = [
    [0.0, 1.5, 0.0],  # out of the space
    [-1.1, 0.0, 0.0],
    [0.0, -0.1, 0.0],
    [0.0, 1.0],  # wrong shape
    [[0.0, 1.0, 0.0]],
    np.zeros(4, np.float32),
    [np.nan, 0.0, 0.0],
    [0.0, np.inf, 0.0],
    np.array([0.0, np.nan, 0.0], np.float32),
    "gas",
    ["a", "b", "c"],
    None,
    3,
]
DISCRETE_INVALID = [5, -1, 3.0, np.float32(1.0), "3", [3], np.array([3]), None, np.nan]


@pytest.mark.parametrize("env_id", PROCEDURAL_IDS)
@pytest.mark.parametrize("action", CONTINUOUS_INVALID, ids=repr)
def test_invalid_continuous_actions_raise_invalid_action(env_id: str, action) -> None:
    env = gym.make(env_id)
    env.reset(seed=0)
    with pytest.raises(InvalidAction, match=r"Box\("):
        env.step(action)
    env.step(np.zeros(3, np.float32))  # the env is still usable


@pytest.mark.parametrize("action", DISCRETE_INVALID, ids=repr)
def test_invalid_discrete_actions_raise_invalid_action(action) -> None:
    env = gym.make("tinyrace/CarRacing-v0", continuous=False)
    env.reset(seed=0)
    with pytest.raises(InvalidAction, match=r"Discrete\(5\)"):
        env.step(action)
    env.step(0)


def test_carracing_v3_also_refuses_out_of_space_actions() -> None:
    """The behaviour being matched: the reference raises the same error type."""
    env = gym.make("CarRacing-v3", continuous=False)
    env.reset(seed=0)
    with pytest.raises(InvalidAction):
        env.step(5)
    env.close()
