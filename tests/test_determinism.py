"""Determinism: the same seed and actions give the same observations, rewards and infos.

Across two envs, across a pickle round trip in the middle of an episode, and
between single envs and a ``gymnasium.vector.SyncVectorEnv`` (autoreset included).
"""

from __future__ import annotations

import pickle
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.examples import TRACKS_DIR

ROOT = Path(__file__).resolve().parents[1]
TRACK = str(TRACKS_DIR / "formula_student")
TWO_CAMERAS = [
    {"id": "front", "resolution": [30, 40], "roi": [360, 480]},
    {"id": "rear", "resolution": [20, 20], "roi": [200, 200], "yaw": 180, "position": [150, 0]},
]

KINDS: dict[str, Callable[..., gym.Env]] = {
    "procedural": lambda **kw: gym.make("tinyrace/CarRacing-v0", **kw),
    "procedural_discrete_randomized": lambda **kw: gym.make(
        "tinyrace/CarRacing-v0", continuous=False, domain_randomize=True, **kw
    ),
    "image": lambda **kw: gym.make("tinyrace/TinyRace-v0", environment=TRACK, **kw),
    "image_dynamic_two_cameras": lambda **kw: gym.make(
        "tinyrace/TinyRace-v0",
        environment=TRACK,
        car={"model": "dynamic"},
        cameras=TWO_CAMERAS,
        **kw,
    ),
}


def short_episodes(kind: str) -> Callable[[], gym.Env]:
    """The env of ``kind`` with 40-step episodes, so that a run crosses resets."""
    if kind.startswith("procedural"):
        return lambda: KINDS[kind](max_episode_steps=40)
    return lambda: KINDS[kind](sim={"step_limit": 40})


def actions_for(env: gym.Env, count: int, seed: int) -> list:
    env.action_space.seed(seed)
    return [env.action_space.sample() for _ in range(count)]


def same(a, b) -> bool:
    """Deep equality of observations and infos: arrays, dicts, sequences, numbers."""
    if isinstance(a, dict) or isinstance(b, dict):
        return (
            isinstance(a, dict)
            and isinstance(b, dict)
            and a.keys() == b.keys()
            and all(same(a[k], b[k]) for k in a)
        )
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b))
    if isinstance(a, (list, tuple)) or isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    return type(a) is type(b) and a == b if not _number(a) else _number(b) and a == b


def _number(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def rollout(env: gym.Env, seed: int, actions: list) -> list[tuple]:
    """(observation, reward, terminated, truncated, info) per step; episodes reset unseeded."""
    results = [(*env.reset(seed=seed), None, None, None)]
    for action in actions:
        observation, reward, terminated, truncated, info = env.step(action)
        results.append((observation, reward, terminated, truncated, info))
        if terminated or truncated:
            results.append((*env.reset(), None, None, None))
    return results


def assert_same_rollouts(a: list[tuple], b: list[tuple]) -> None:
    assert len(a) == len(b)
    for step, (x, y) in enumerate(zip(a, b, strict=True)):
        assert same(x, y), f"step {step} differs"


@pytest.mark.parametrize("kind", list(KINDS))
def test_same_seed_and_actions_give_identical_rollouts(kind):
    make = short_episodes(kind)
    first, second = make(), make()
    actions = actions_for(first, 120, seed=7)
    a, b = rollout(first, 11, actions), rollout(second, 11, actions)
    assert_same_rollouts(a, b)
    assert sum(r[2] is True or r[3] is True for r in a) >= 2  # it crossed episode ends
    # and the same env run again from the same seed repeats itself
    assert_same_rollouts(rollout(first, 11, actions), a)


def test_the_comparison_can_fail():
    """``same`` tells apart what a nondeterministic env would change."""
    assert not same({"pose": (1.0, 2.0, 0.0)}, {"pose": (1.0, 2.0, 1e-12)})
    assert not same(np.zeros((2, 2), np.uint8), np.eye(2, dtype=np.uint8))
    assert not same({"a": 1}, {"a": 1, "b": 2})
    assert same({"x": [np.float64(1.5), 2]}, {"x": (1.5, np.int64(2))})


@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("wrapped", [True, False], ids=["gym.make", "unwrapped"])
def test_pickle_mid_episode_continues_identically(kind, wrapped):
    env = short_episodes(kind)()
    env = env if wrapped else env.unwrapped
    actions = actions_for(env, 90, seed=5)
    env.reset(seed=21)
    for action in actions[:25]:  # mid-episode: moving, tiles visited, skid marks drawn
        env.step(action)
    clone = pickle.loads(pickle.dumps(env))
    a = [env.step(action) for action in actions[25:35]]
    b = [clone.step(action) for action in actions[25:35]]
    assert_same_rollouts(a, b)
    # and both reset alike afterwards (the rng state travelled too)
    assert same(env.reset(), clone.reset())
    assert same(env.step(actions[40]), clone.step(actions[40]))


def unbatch(info: dict, index: int) -> dict:
    """The info of sub-env ``index`` out of a vector env's batched info."""
    single = {}
    for key, value in info.items():
        if key.startswith("_") or not info.get(f"_{key}", np.zeros(index + 1, bool))[index]:
            continue
        single[key] = unbatch(value, index) if isinstance(value, dict) else value[index]
    return single


def autoreset_reference(env: gym.Env, seed: int, actions: list) -> list[tuple]:
    """A single env stepped the way a vector env does (next-step autoreset)."""
    observation, info = env.reset(seed=seed)
    results, done = [(observation, info)], False
    for action in actions:
        if done:  # the step after an episode's end only resets: reward 0, not done
            observation, info = env.reset()
            results.append((observation, 0.0, False, False, info))
            done = False
            continue
        observation, reward, terminated, truncated, info = env.step(action)
        results.append((observation, reward, terminated, truncated, info))
        done = terminated or truncated
    return results


def vector_rollout(vector: gym.vector.VectorEnv, seeds: list[int], batched: list) -> list:
    """Per step, per sub-env: (observation, reward, terminated, truncated, info)."""
    observations, infos = vector.reset(seed=seeds)
    steps = [[(_index(observations, i), unbatch(infos, i)) for i in range(len(seeds))]]
    for action in batched:
        observations, rewards, terminated, truncated, infos = vector.step(action)
        steps.append(
            [
                (
                    _index(observations, i),
                    float(rewards[i]),
                    bool(terminated[i]),
                    bool(truncated[i]),
                    unbatch(infos, i),
                )
                for i in range(len(seeds))
            ]
        )
    return steps


def _index(observations, i: int):
    if isinstance(observations, dict):
        return {key: value[i] for key, value in observations.items()}
    return observations[i]


@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("count", [1, 2])
def test_sync_vector_env_matches_single_envs(kind, count):
    make = short_episodes(kind)
    seeds = [30 + i for i in range(count)]
    vector = gym.vector.SyncVectorEnv([make] * count)
    singles = [make() for _ in range(count)]
    per_env = [actions_for(singles[i], 100, seed=50 + i) for i in range(count)]
    batched = [_batch(vector, [per_env[i][t] for i in range(count)]) for t in range(100)]
    got = vector_rollout(vector, seeds, batched)
    for i, single in enumerate(singles):
        expected = autoreset_reference(single, seeds[i], per_env[i])
        ends = sum(e[2] is True or e[3] is True for e in expected if len(e) == 5)
        assert ends >= 2  # autoresets happened
        for step, (want, have) in enumerate(zip(expected, (s[i] for s in got), strict=True)):
            assert same(want, have), f"sub-env {i}, step {step} differs"
    vector.close()


def _batch(vector: gym.vector.VectorEnv, actions: list):
    if isinstance(vector.single_action_space, gym.spaces.Discrete):
        return np.array(actions, np.int64)
    return np.stack(actions)


def test_different_seeds_give_different_procedural_tracks():
    env = gym.make("tinyrace/CarRacing-v0").unwrapped
    tracks = []
    for seed in range(6):
        env.reset(seed=seed)
        tracks.append(np.array(env.track.centerline))
    for i in range(len(tracks)):
        for j in range(i):
            assert tracks[i].shape != tracks[j].shape or not np.allclose(tracks[i], tracks[j])
    env.reset(seed=3)
    np.testing.assert_array_equal(env.track.centerline, tracks[3])  # and the same seed repeats


class InParts(gym.Wrapper):
    """Steps its env in the parts of the stepping protocol a batched stepper uses: control,
    the world's forces, advance (the world's step and the rules), conclude."""

    def step(self, action):
        raw = self.env.unwrapped
        raw.control(action)
        raw.world.apply_forces(raw.dt)
        return raw.conclude(raw.advance())


@pytest.mark.parametrize("kind", ["procedural", "image_dynamic_two_cameras"])
def test_a_step_in_parts_is_a_step(kind):
    whole = KINDS[kind]()
    parts = InParts(KINDS[kind]())
    actions = actions_for(whole, 60, seed=3)
    assert_same_rollouts(rollout(parts, 5, actions), rollout(whole, 5, actions))
