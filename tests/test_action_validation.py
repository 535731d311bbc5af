"""Hostile actions and long random runs: no NaN ever enters the simulation.

Every action is either refused with ``gymnasium.error.InvalidAction`` (and the env
is left exactly as it was) or accepted as ``tinyrace/actions.py``'s docstring says:
real-valued array-likes of the right shape for a Box, integers for Discrete(5).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import InvalidAction
from hypothesis_budget import size

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.examples import TRACKS_DIR

ROOT = Path(__file__).resolve().parents[1]
TRACK = str(TRACKS_DIR / "formula_student")
LONG_RUN_STEPS = size(20_000, 5_000)  # steps per track kind; 5,000 in the quick run
PROCEDURAL_TOP_SPEED = 100.0  # [u/s] CarRacing's Box2D cap: 2 u per step at 50 steps/s

ENVS = {
    "procedural": lambda: gym.make("tinyrace/CarRacing-v0"),
    "procedural_discrete": lambda: gym.make("tinyrace/CarRacing-v0", continuous=False),
    "image": lambda: gym.make("tinyrace/TinyRace-v0", environment=TRACK),
    "image_dynamic": lambda: gym.make(
        "tinyrace/TinyRace-v0", environment=TRACK, car={"model": "dynamic"}
    ),
}


def snapshot(env: gym.Env) -> tuple:
    """Everything a step changes: the clock, the score, the body and the car's own state."""
    base = env.unwrapped
    car = base.car
    body = car.body
    state = (
        base.t,
        base.steps,
        base.score,
        tuple(body.position),
        body.angle,
        tuple(body.velocity),
        body.angular_velocity,
        tuple(body.force),
        body.torque,
    )
    if hasattr(car, "wheels"):
        wheels = tuple((w.omega, w.steer, w.gas, w.brake, w.phase) for w in car.wheels)
        return (*state, car.steer_target, wheels)
    return (*state, car.steer, car.steer_target)


def assert_finite_state(env: gym.Env, info: dict) -> None:
    car = env.unwrapped.car
    body = car.body
    values = [
        *info["pose"],
        info["speed"],
        *body.position,
        body.angle,
        *body.velocity,
        body.angular_velocity,
    ]
    if hasattr(car, "wheels"):
        values += [v for w in car.wheels for v in (w.omega, w.steer, w.gas, w.brake)]
    assert all(math.isfinite(v) for v in values), values


def speed_cap(env: gym.Env) -> float:
    """[track units/s] the dynamic car's top speed: 2 u per step, in track units."""
    base = env.unwrapped
    return base.car.spec.max_translation * base.car.scale * base.config.sim.fps


def arc_length(before: tuple, after: tuple, turn_rate: float, dt: float) -> float:
    """[px] the length of the circular arc from pose ``before`` to ``after`` at ``turn_rate``."""
    chord = math.dist(before[:2], after[:2])
    half = turn_rate * dt / 2  # [rad] the chord's angle to the arc's ends
    return chord * half / math.sin(half) if half else chord


# -- long random runs ------------------------------------------------------------------------
def corner_actions(space: gym.Space) -> list:
    """The vertices of a Box (full lock, full gas and brake): the hardest in-space inputs."""
    if not isinstance(space, gym.spaces.Box):
        return list(range(space.n))
    grids = np.meshgrid(*zip(space.low, space.high, strict=True))
    return [np.array(v, np.float32) for v in np.stack([g.ravel() for g in grids], axis=1)]


def random_actions(space: gym.Space, count: int, rng: np.random.Generator) -> list:
    """In-space actions: uniform draws, and one block of 50 steps in two held at a corner."""
    corners = corner_actions(space)
    if isinstance(space, gym.spaces.Box):
        drawn = rng.uniform(space.low, space.high, (count, *space.shape)).astype(np.float32)
    else:
        drawn = rng.integers(space.n, size=count)
    actions = list(drawn)
    for start in range(0, count, 100):  # full lock, full gas, full brake: the hardest inputs
        actions[start : start + 50] = [corners[rng.integers(len(corners))]] * 50
    return actions[:count]


@pytest.mark.parametrize("kind", ["procedural", "image", "image_dynamic"])
def test_long_random_run_stays_finite_and_bounded(kind):
    """20,000 in-space steps on one track kind (5,000 in the quick run): finite state, bounded
    speed, every step.

    The state is recorded per step and checked at the end (cheaper than asserting per step).
    """
    env = ENVS[kind]()
    base = env.unwrapped
    actions = random_actions(env.action_space, LONG_RUN_STEPS, np.random.default_rng(1))
    kinematic = base.config.car.model == "kinematic"
    # per step: x, y, heading, info speed, |body velocity|, vx, vy, angular velocity, reward
    record = np.empty((LONG_RUN_STEPS, 9))
    arcs = np.full(LONG_RUN_STEPS, np.nan)  # kinematic: the arc driven in each step [px]
    _, info = env.reset(seed=1)
    pose, resets = info["pose"], 0
    for step, action in enumerate(actions):
        _, reward, terminated, truncated, info = env.step(action)
        body = base.car.body
        (vx, vy), spin = body.velocity, body.angular_velocity
        record[step] = (*info["pose"], info["speed"], math.hypot(vx, vy), vx, vy, spin, reward)
        if kinematic:
            arcs[step] = arc_length(pose, info["pose"], spin, base.dt)
        pose = info["pose"]
        if terminated or truncated:
            _, info = env.reset()
            pose = info["pose"]
            resets += 1
    env.close()
    assert np.isfinite(record).all(), np.argwhere(~np.isfinite(record))[:5]
    assert resets >= LONG_RUN_STEPS // 1000 - 1  # the run crossed many episodes
    speeds = record[:, 4]
    if kinematic:
        velocity = base.config.car.velocity
        assert np.all(record[:, 3] == velocity)  # info["speed"]
        np.testing.assert_allclose(arcs, velocity * base.dt, rtol=1e-9)
    else:
        cap = PROCEDURAL_TOP_SPEED if kind == "procedural" else speed_cap(env)
        assert speeds.max() <= cap * (1 + 1e-9), (speeds.max(), cap)
        assert speeds.max() > 0.3 * cap  # the corner actions did drive the car fast
        np.testing.assert_allclose(record[:, 3], speeds, rtol=1e-12)  # info["speed"]: the body


# -- hostile actions ---------------------------------------------------------------------------
class Odd:
    """An object numpy cannot make numbers of."""


BOX3 = "procedural"
NAN, INF = math.nan, math.inf
BOX3_ACCEPTED = [
    np.array([0.1, 0.5, 0.0], np.float32),
    np.array([0.1, 0.5, 0.0], np.float64),
    np.array([0.1, 0.5, 0.0], np.float16),
    np.array([-1, 1, 1], np.int64),
    np.array([0, 1, 0], np.uint8),
    [0.1, 0.5, 0.0],
    (0.1, 0.5, 0.0),
    [np.float32(0.1), np.float64(0.5), 0],
    [-1.0, 1.0, 1.0],  # the bounds themselves
    np.array([[0.1, 9.0], [0.5, 9.0], [0.0, 9.0]], np.float32)[:, 0],  # a strided view
    np.ma.masked_array([0.1, 0.5, 0.0], mask=[0, 0, 0]),
]
BOX3_REJECTED = [
    [NAN, 0.5, 0.0],
    [0.1, NAN, 0.0],
    np.array([0.1, 0.5, NAN], np.float32),
    [INF, 0.0, 0.0],
    [0.0, -INF, 0.0],
    [1e300, 0.0, 0.0],  # inf as float32
    [1.5, 0.0, 0.0],
    [0.0, -0.1, 0.0],
    [0.0, 0.0, 1.0001],
    [1.0000001, 0.0, 0.0],  # above 1 even though float32 would round it to 1
    np.array([0.1, 0.5], np.float32),
    np.array([0.1, 0.5, 0.0, 0.0], np.float32),
    np.array([[0.1, 0.5, 0.0]], np.float32),
    np.float32(0.5),
    np.array(0.5),
    0.5,
    1,
    None,
    "abc",
    ["0.1", "0.5", "0"],
    np.array(["a", "b", "c"]),
    b"abc",
    np.array([0.1, 0.5, 0.0], dtype=object),
    np.array([0.1 + 0j, 0.5, 0.0]),
    np.array([True, False, True]),
    [True, False, True],
    {"steer": 0.1},
    [[0.1], 0.5, 0.0],  # ragged
    [Odd(), 0.5, 0.0],
    [2**70, 0, 0],
    np.array([1, 2, 3], dtype="timedelta64[s]"),
]
BOX1_ACCEPTED = [
    np.array([0.5], np.float32),
    np.array([-1.0], np.float64),
    np.array([1], np.int32),
    [0.5],
    (0.5,),
    [np.float64(-0.25)],
]
BOX1_REJECTED = [
    0.5,
    np.float32(0.5),
    np.array(0.5, np.float32),
    [[0.5]],
    [0.5, 0.5],
    [],
    [NAN],
    np.array([INF], np.float32),
    [-1.5],
    [True],
    ["0.5"],
    [0.5 + 0j],
    np.array([0.5], dtype=object),
    None,
    Odd(),
]
DISCRETE_ACCEPTED = [
    0,
    4,
    np.int64(3),
    np.int8(2),
    np.uint8(1),
    np.array(3),
    np.array(1, np.uint16),
]
DISCRETE_REJECTED = [
    5,
    -1,
    2**70,
    np.uint64(2**63),
    3.0,
    np.float64(3.0),
    np.array(3.0),
    True,
    np.bool_(True),
    "3",
    [3],
    (3,),
    np.array([3]),
    None,
    NAN,
    Odd(),
]
CASES = {
    "procedural": (BOX3_ACCEPTED, BOX3_REJECTED),
    "image_dynamic": (BOX3_ACCEPTED, BOX3_REJECTED),
    "image": (BOX1_ACCEPTED, BOX1_REJECTED),
    "procedural_discrete": (DISCRETE_ACCEPTED, DISCRETE_REJECTED),
}


@pytest.fixture(scope="module")
def envs():
    made = {kind: make() for kind, make in ENVS.items()}
    yield made
    for env in made.values():
        env.close()


@pytest.mark.parametrize("kind", list(CASES))
def test_rejected_actions_raise_invalid_action_and_change_nothing(envs, kind):
    env = envs[kind]
    env.reset(seed=3)
    for _ in range(5):  # moving, so that a changed state would show
        env.step(env.action_space.sample())
    for action in CASES[kind][1]:
        before = snapshot(env)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no RuntimeWarning (overflow in a cast) either
            with pytest.raises(InvalidAction, match=r"Box|Discrete") as caught:
                env.step(action)
        assert str(env.action_space) in str(caught.value), str(caught.value)
        assert snapshot(env) == before, repr(action)
    # the env still works after all those refusals
    _, reward, _, _, info = env.step(env.action_space.sample())
    assert math.isfinite(reward)
    assert_finite_state(env, info)


@pytest.mark.parametrize("kind", list(CASES))
def test_accepted_actions_act_as_their_float32_or_int_values(envs, kind):
    """An accepted action does what the same values as a float32 array (or an int) do."""
    env = envs[kind]
    env.reset(seed=4)
    at_rest = snapshot(env)
    for action in CASES[kind][0]:
        results = []
        for given in (action, _canonical(action, env.action_space)):
            env.reset(seed=4)
            observation, reward, _, _, info = env.step(given)
            results.append((observation, reward, info["pose"], snapshot(env)))
        (obs_a, *rest_a), (obs_b, *rest_b) = results
        assert same_observation(obs_a, obs_b), repr(action)
        assert rest_a == rest_b, repr(action)
        if not (isinstance(env.action_space, gym.spaces.Discrete) and int(action) == 0):
            # (Discrete 0 is "do nothing")
            assert rest_a[-1][3:] != at_rest[3:], repr(action)  # the car moved or steered


def same_observation(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    return np.array_equal(a, b)


def _canonical(action, space: gym.Space):
    if isinstance(space, gym.spaces.Discrete):
        return int(action)
    return np.asarray(action, np.float64).astype(np.float32)


def test_a_masked_value_is_read_as_its_data_not_as_none():
    """tolist() of a masked array gives None for masked values; the env must not see them."""
    env = ENVS["procedural"]()
    env.reset(seed=0)
    action = np.ma.masked_array([0.0, 1.0, 0.0], mask=[0, 1, 0])
    _, _, _, _, info = env.step(action)
    assert_finite_state(env, info)
    assert env.unwrapped.car.wheels[2].gas > 0  # the gas under the mask was used
    env.close()


def test_step_before_reset_is_refused():
    env = ENVS["image"]().unwrapped
    with pytest.raises(gym.error.ResetNeeded):
        env.step(np.zeros(1, np.float32))
