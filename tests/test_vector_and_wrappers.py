"""Gymnasium's vector envs and observation wrappers on tinyrace's envs.

Vector envs: SyncVectorEnv and AsyncVectorEnv (2 workers, "spawn") on the
procedural track (Box observations) and an image track with two cameras (Dict
observations): batched shapes, next-step autoreset, and the same results as a
SyncVectorEnv.

Wrappers on tinyrace/CarRacing-v0: GrayscaleObservation, ResizeObservation,
FrameStackObservation and RecordVideo. On Dict observations (image tracks),
FrameStackObservation stacks each camera; GrayscaleObservation and
ResizeObservation take a Box only (Gymnasium refuses a Dict): apply them per camera,
or configure the camera's resolution instead of resizing.
"""

from __future__ import annotations

import functools
import itertools
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import (
    FrameStackObservation,
    GrayscaleObservation,
    RecordVideo,
    ResizeObservation,
)

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.examples import TRACKS_DIR

ROOT = Path(__file__).resolve().parents[1]
TRACK = str(TRACKS_DIR / "segmented")
CAMERAS = [
    {"id": "front", "resolution": [30, 40], "roi": [360, 480]},
    {"id": "rear", "resolution": [20, 24], "roi": [200, 240], "yaw": 180, "position": [150, 0]},
]
EPISODE = 20  # [steps] short episodes, so that 50 steps cross two autoresets

# "tinyrace:<id>" makes gym.make import tinyrace first: spawned workers register the ids too.
FACTORIES = {
    "procedural": functools.partial(
        gym.make, "tinyrace:tinyrace/CarRacing-v0", max_episode_steps=EPISODE
    ),
    "image_two_cameras": functools.partial(
        gym.make,
        "tinyrace:tinyrace/TinyRace-v0",
        environment=TRACK,
        cameras=CAMERAS,
        sim={"step_limit": EPISODE},
    ),
}
SHAPES = {
    "procedural": (96, 96, 3),
    "image_two_cameras": {"front": (30, 40, 3), "rear": (20, 24, 3)},
}


def batched_shapes(observations) -> object:
    if isinstance(observations, dict):
        return {key: value.shape for key, value in observations.items()}
    return observations.shape


def expected_shapes(kind: str, count: int) -> object:
    shape = SHAPES[kind]
    if isinstance(shape, dict):
        return {key: (count, *value) for key, value in shape.items()}
    return (count, *shape)


def run_vector(vector: gym.vector.VectorEnv, kind: str, steps: int = 50) -> list[tuple]:
    """reset + ``steps`` steps; checks shapes and dtypes; returns every step's outputs."""
    observations, _ = vector.reset(seed=[3, 4])
    assert batched_shapes(observations) == expected_shapes(kind, 2)
    assert vector.observation_space.contains(observations)
    vector.action_space.seed(9)
    history = [(observations, None, None, None)]
    for _ in range(steps):
        observations, rewards, terminated, truncated, _ = vector.step(vector.action_space.sample())
        assert batched_shapes(observations) == expected_shapes(kind, 2)
        assert vector.observation_space.contains(observations)
        assert rewards.shape == terminated.shape == truncated.shape == (2,)
        assert terminated.dtype == truncated.dtype == np.bool_
        history.append((observations, rewards, terminated, truncated))
    vector.close()
    return history


def check_autoreset(history: list[tuple]) -> None:
    """Next-step autoreset: the step after an episode's end resets (reward 0, not done)."""
    ends = 0
    for (_, _, term, trunc), (_, rewards, term_next, trunc_next) in itertools.pairwise(history[1:]):
        for i in np.flatnonzero(term | trunc):
            ends += 1
            assert rewards[i] == 0.0
            assert not term_next[i] and not trunc_next[i]
    assert ends >= 4  # both sub-envs ended an episode at least twice in 50 steps


def first(observations):
    return observations if not isinstance(observations, dict) else observations["front"]


@pytest.mark.parametrize("kind", list(FACTORIES))
def test_sync_vector_env(kind):
    history = run_vector(gym.vector.SyncVectorEnv([FACTORIES[kind]] * 2), kind)
    check_autoreset(history)
    reset = first(history[0][0])
    assert not np.array_equal(reset[0], reset[1]) or kind != "procedural"  # seeds 3 and 4


@pytest.mark.parametrize("kind", list(FACTORIES))
def test_async_vector_env_matches_sync(kind):
    """Two spawned workers give exactly what the SyncVectorEnv gives."""
    sync = run_vector(gym.vector.SyncVectorEnv([FACTORIES[kind]] * 2), kind)
    spawned = gym.vector.AsyncVectorEnv([FACTORIES[kind]] * 2, context="spawn")
    got = run_vector(spawned, kind)
    check_autoreset(got)
    for step, (a, b) in enumerate(zip(sync, got, strict=True)):
        for x, y in zip(a, b, strict=True):
            if isinstance(x, dict):
                assert all(np.array_equal(x[k], y[k]) for k in x), step
            else:
                assert np.array_equal(x, y), step


# -- wrappers ----------------------------------------------------------------------------------
def carracing(**kwargs) -> gym.Env:
    return gym.make("tinyrace/CarRacing-v0", **kwargs)


def paired_steps(wrapped: gym.Env, raw: gym.Env, steps: int = 5):
    """Step a wrapped env and an unwrapped twin alike; yield both observations per step."""
    wrapped.action_space.seed(2)
    yield wrapped.reset(seed=2)[0], raw.reset(seed=2)[0]
    for _ in range(steps):
        action = wrapped.action_space.sample()
        yield wrapped.step(action)[0], raw.step(action)[0]


def test_grayscale_observation():
    env = GrayscaleObservation(carracing())
    assert env.observation_space.shape == (96, 96)
    for gray, rgb in paired_steps(env, carracing()):
        assert gray.shape == (96, 96) and gray.dtype == np.uint8
        weights = np.array([0.2125, 0.7154, 0.0721])  # Gymnasium's luminance weights
        np.testing.assert_array_equal(gray, np.sum(rgb * weights, axis=-1).astype(np.uint8))
    assert len(np.unique(gray)) > 3  # a picture, not a flat frame


def test_resize_observation():
    env = ResizeObservation(carracing(), (64, 48))
    assert env.observation_space.shape == (64, 48, 3)
    for small, rgb in paired_steps(env, carracing()):
        assert small.shape == (64, 48, 3) and env.observation_space.contains(small)
        expected = cv2.resize(rgb, (48, 64), interpolation=cv2.INTER_AREA)
        assert np.abs(small.astype(int) - expected).mean() < 8  # the same picture, smaller


def test_frame_stack_of_grayscale():
    env = FrameStackObservation(GrayscaleObservation(carracing()), stack_size=4)
    assert env.observation_space.shape == (4, 96, 96)
    frames = []
    for stack, rgb in paired_steps(env, GrayscaleObservation(carracing())):
        frames.append(rgb)
        assert stack.shape == (4, 96, 96) and env.observation_space.contains(stack)
        np.testing.assert_array_equal(stack[-1], frames[-1])
        if len(frames) >= 4:
            np.testing.assert_array_equal(stack, np.stack(frames[-4:]))


def test_frame_stack_of_dict_observations():
    env = FrameStackObservation(FACTORIES["image_two_cameras"](), stack_size=3)
    assert {k: s.shape for k, s in env.observation_space.items()} == {
        "front": (3, 30, 40, 3),
        "rear": (3, 20, 24, 3),
    }
    frames = []
    for stack, single in paired_steps(env, FACTORIES["image_two_cameras"]()):
        frames.append(single)
        assert env.observation_space.contains(stack)
        for key in ("front", "rear"):
            np.testing.assert_array_equal(stack[key][-1], single[key])
            if len(frames) >= 3:
                np.testing.assert_array_equal(stack[key], np.stack([f[key] for f in frames[-3:]]))


def test_grayscale_and_resize_take_a_box_only():
    """What does not apply to Dict observations (see the module docstring)."""
    for wrapper in (GrayscaleObservation, lambda env: ResizeObservation(env, (16, 16))):
        with pytest.raises((AssertionError, TypeError), match="Box"):
            wrapper(FACTORIES["image_two_cameras"]())


def test_record_video_writes_an_mp4(tmp_path):
    env = RecordVideo(
        carracing(render_mode="rgb_array", max_episode_steps=30),
        str(tmp_path / "videos"),
        episode_trigger=lambda episode: True,
        disable_logger=True,
    )
    env.reset(seed=0)
    env.action_space.seed(0)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        done = terminated or truncated
    env.close()
    videos = sorted((tmp_path / "videos").glob("*.mp4"))
    assert len(videos) == 1, list(tmp_path.iterdir())
    capture = cv2.VideoCapture(str(videos[0]))
    frames = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
    size = (int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)), int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT)))
    ok, frame = capture.read()
    capture.release()
    assert ok and frame.std() > 5  # a real picture
    assert size == (600, 400)
    assert frames == 31  # the reset frame and 30 steps
