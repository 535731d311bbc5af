"""Every sensor type in the env: check_env on every track kind it supports (ConfigError on
the others; the metric kinds by their shipped examples), pickling, determinism for a seed,
and the vector envs."""

from __future__ import annotations

import functools
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.config.schema import track_configs
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.sensors.registry import SENSOR_TYPES
from tinyrace.vector import make_batch

ID = "tinyrace:tinyrace/TinyRace-v0"  # spawned workers import tinyrace first
KINDS = {
    "procedural": {},
    "image": {"environment": str(TRACKS_DIR / "formula_student")},
    "centerline": {"environment": str(TRACKS_DIR / "circuit")},
    "cone_map": {"environment": str(TRACKS_DIR / "autocross")},
    "ros_map": {"environment": str(TRACKS_DIR / "f1tenth_loop")},
}
ENTRIES = {  # small and noisy: noise must come from the env's seed
    "perspective_camera": {"resolution": [30, 40], "max_range": 60.0},
    "lidar": {"beams": 90, "range_std": 0.05, "dropout": 0.1},
    "state": {"pose": True},
    "lookahead": {"points": 5},
    "cones": {"max_cones": 8, "position_std": 0.5, "miss_probability": 0.2, "false_positives": 1},
    "opponents": {"count": 2},
    "chase_view": {"resolution": [64, 80]},
    "top_view": {"resolution": [48, 40], "span": 10.0},
}
CLASSES = {
    "id": "labels",
    "type": "perspective_camera",
    "resolution": [24, 32],
    "format": "classes",
}


HOLDS = {name: c.holds for name, c in track_configs().items()}


def supported(sensor: str, kind: str) -> bool:
    needs = SENSOR_TYPES[sensor].needs  # what the track must hold, e.g. cones
    return needs is None or needs in HOLDS[kind]


def entries(sensor: str) -> list[dict]:
    return [{"id": sensor, "type": sensor, **ENTRIES[sensor]}]


def make(sensor: str, kind: str, **kwargs) -> gym.Env:
    return gym.make(ID, sensors=entries(sensor), **KINDS[kind], **kwargs)


def actions(env: gym.Env, seed: int = 0):
    env.action_space.seed(seed)
    while True:
        yield env.action_space.sample()


def rollout(env: gym.Env, seed: int, steps: int = 12) -> list:
    observation, _ = env.reset(seed=seed)
    seen = [observation]
    for action, _ in zip(actions(env), range(steps), strict=False):
        observation, *_ = env.step(action)
        seen.append(observation)
    return seen


def same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    return np.array_equal(a, b)


def test_every_sensor_type_is_tested():
    assert set(ENTRIES) == set(SENSOR_TYPES) - {"birdseye_camera"}  # cameras: tested elsewhere


CASES = [(s, k) for s in ENTRIES for k in KINDS]  # birdseye_camera: cameras' own tests


@pytest.mark.parametrize(("sensor", "kind"), CASES)
def test_check_env_or_config_error(sensor, kind):
    if not supported(sensor, kind):
        with pytest.raises(ConfigError, match=f"sensors\\[0\\].*{sensor}"):
            make(sensor, kind)
        return
    env = make(sensor, kind)
    check_env(env.unwrapped, skip_render_check=True)
    observation, _ = env.reset(seed=1)
    assert env.observation_space.contains(observation)
    env.close()


@pytest.mark.parametrize(("sensor", "kind"), [c for c in CASES if supported(*c)])
def test_same_seed_same_observations_and_pickles(sensor, kind):
    env = make(sensor, kind)
    first = rollout(env, seed=5)
    assert all(same(a, b) for a, b in zip(first, rollout(env, seed=5), strict=True))
    env.reset(seed=6)
    env.step(env.action_space.sample())
    copy = pickle.loads(pickle.dumps(env))
    action = env.action_space.sample()
    assert same(env.step(action)[0], copy.step(action)[0])


def test_noise_differs_between_seeds():
    a = rollout(make("lidar", "procedural"), seed=1, steps=0)[0]["lidar"]
    b = rollout(make("lidar", "procedural"), seed=2, steps=0)[0]["lidar"]
    assert not np.array_equal(a, b)


def test_classes_format_is_labels_with_a_table_in_info():
    env = gym.make(ID, sensors=[CLASSES], **KINDS["image"])
    observation, info = env.reset(seed=0)
    table = info["sensor_labels"]["labels"]  # {label: name}
    assert (table[0], table[1], table[255]) == ("background", "road", "sky")
    assert any("obstacle" in name for name in table.values())
    labels = observation["labels"]
    assert labels.dtype == np.uint8 and labels.shape == (24, 32)
    assert set(np.unique(labels)) <= set(table) and 255 in labels  # the sky is named too


def _vector_rollout(vector, steps: int = 12) -> list:
    observation, _ = vector.reset(seed=3)
    seen = [observation]
    vector.action_space.seed(0)
    for _ in range(steps):
        seen.append(vector.step(vector.action_space.sample())[0])
    vector.close()
    return seen


def _several_kwargs() -> dict:
    sensors = [{"id": s, "type": s, **ENTRIES[s]} for s in ENTRIES if supported(s, "image")]
    return {"sensors": sensors, "sim": {"step_limit": 8}, **KINDS["image"]}


_several = functools.partial(gym.make, ID, **_several_kwargs())  # picklable for workers


def test_sensors_in_every_vector_env():
    sync = _vector_rollout(gym.vector.SyncVectorEnv([_several] * 2))
    spawned = gym.vector.AsyncVectorEnv([_several] * 2, context="spawn")
    batch = make_batch(ID, 2, workers=1, context="spawn", **_several_kwargs())
    for other in (_vector_rollout(spawned), _vector_rollout(batch)):
        assert all(same(a, b) for a, b in zip(sync, other, strict=True))
