"""What envs stepped together in one process share, and what a batch no longer copies.

- The car's cached pictures (``car_sprite``) are drawn from the placement their key stands
  for, so a cached picture gives the pixels the car's own pose gives, whichever pose first
  drew it; the views of a process share them.
- A Box observation's sensor that can draw into a given array (``DrawsInto``) draws the
  same pixels there; a vector env in one process draws every env's observation straight
  into its row, with no per-env copy.
- The warp's 4-channel scratch is one per size and thread, not one per texture.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.ground import texture
from tinyrace.sensors.chase_view import ZOOM, chase_affine
from tinyrace.sensors.machinery import car_sprite
from tinyrace.sensors.machinery.car_sprite import CarSprite
from tinyrace.vector import envslice, make_batch

SIZE = (96, 96)  # [px] the observation's (w, h)


def _car(seed: int = 0, steps: int = 30):
    """A CarRacing car's state after ``steps`` steps of steering left with some gas."""
    env = gym.make("tinyrace/CarRacing-v0")
    env.reset(seed=seed)
    for _ in range(steps):
        env.step(np.array([-0.6, 0.4, 0.0], np.float32))
    car = env.unwrapped.snapshot().car
    env.close()
    return car


def _draw(sprite: CarSprite, car, cached: bool) -> np.ndarray:
    """``car`` drawn into a blank frame of the chase view at full zoom."""
    zoom = ZOOM / car.scale
    frame = np.zeros((SIZE[1], SIZE[0], 3), np.uint8)
    world_to_out = chase_affine(car.pose[:2], car.hull_angle, zoom, SIZE)
    placement = (lambda key: chase_affine((0.0, 0.0), 0.0, key, SIZE)) if cached else None
    sprite.draw(frame, car, world_to_out, 0, zoom if cached else None, placement)
    return frame


@pytest.mark.parametrize(
    "pose", [(0.0, 0.0, 0.0), (250.0, -130.0, 2.0), (-317.25, 88.5, -2.9), (1e3, 1e3, 0.7)]
)
def test_a_cached_car_picture_is_the_one_its_pose_draws(monkeypatch, pose):
    """The cache is filled at one pose, then read at another: the pixels are those the
    second pose draws without the cache (the picture is the key's, not the first pose's)."""
    car = _car()
    monkeypatch.setattr(car_sprite, "_SHARED", {})  # none of the env's pictures
    x, y, angle = pose
    elsewhere = car._replace(pose=(x, y, car.pose[2]), hull_angle=angle)
    assert car.pose[:2] != elsewhere.pose[:2]
    fresh = _draw(CarSprite(supersample=True), elsewhere, cached=False)
    assert fresh.any()  # the car is in the frame
    filler, reader = CarSprite(supersample=True), CarSprite(supersample=True)
    np.testing.assert_array_equal(_draw(filler, car, cached=True), fresh)  # fills the cache
    np.testing.assert_array_equal(_draw(reader, elsewhere, cached=True), fresh)
    assert sum(len(patches) for patches in car_sprite._SHARED.values()) == 1  # drawn once


def test_views_of_a_process_share_the_car_pictures(monkeypatch):
    """Two sprites drawing the same car into frames of one size share one cache; another
    frame size or another car size has its own."""
    car = _car()
    monkeypatch.setattr(car_sprite, "_SHARED", {})  # none of the env's pictures
    first, second = CarSprite(supersample=True), CarSprite(supersample=True)
    _draw(first, car, cached=True)
    _draw(second, car._replace(pose=(5.0, 6.0, 0.0), hull_angle=1.0), cached=True)
    assert len(car_sprite._SHARED) == 1
    bigger = CarSprite(supersample=True)
    frame = np.zeros((100, 120, 3), np.uint8)
    zoom = ZOOM / car.scale
    affine = chase_affine(car.pose[:2], car.hull_angle, zoom, (120, 100))
    bigger.draw(frame, car, affine, 0, zoom, lambda key: chase_affine((0, 0), 0.0, key, (120, 100)))
    _draw(CarSprite(supersample=True), car._replace(scale=car.scale * 2), cached=True)
    assert len(car_sprite._SHARED) == 3


def test_an_env_observes_the_same_whoever_drew_the_pictures_first(monkeypatch):
    """An env's observations through its zoom-in and after do not depend on which env (or
    episode) first drew the car's pictures of the process."""
    action = np.array([0.3, 0.5, 0.0], np.float32)

    def observations(env) -> list[np.ndarray]:
        first, _ = env.reset(seed=0)
        return [first] + [env.step(action)[0] for _ in range(60)]

    monkeypatch.setattr(car_sprite, "_SHARED", {})
    alone = observations(gym.make("tinyrace/CarRacing-v0"))
    monkeypatch.setattr(car_sprite, "_SHARED", {})
    other = gym.make("tinyrace/CarRacing-v0")
    other.reset(seed=5)
    for step in range(60):
        other.step(np.array([math.sin(step / 7), 0.5, 0.0], np.float32))
    after = observations(gym.make("tinyrace/CarRacing-v0"))
    for index, (a, b) in enumerate(zip(alone, after, strict=True)):
        np.testing.assert_array_equal(a, b, err_msg=f"step {index}")


def test_observe_draws_a_box_observation_into_the_given_array():
    env = gym.make("tinyrace/CarRacing-v0")
    env.reset(seed=2)
    for _ in range(20):
        env.step(np.array([0.1, 0.6, 0.0], np.float32))
    core = env.unwrapped
    assert core.draws_into
    snapshot = core.snapshot()
    out = np.zeros(env.observation_space.shape, np.uint8)
    assert core.observe(snapshot, out) is out
    np.testing.assert_array_equal(out, core.observe(snapshot))


def test_observe_ignores_the_array_where_the_sensor_cannot_draw_into_it():
    """A lidar's reading is no image: ``observe`` returns its own array, ``out`` untouched."""
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment="formula_student",
        sensors=[{"type": "lidar", "id": "lidar", "beams": 16}],
        cameras=[],
        observation="box",
    )
    env.reset(seed=0)
    core = env.unwrapped
    assert not core.draws_into
    out = np.full(env.observation_space.shape, -1.0, env.observation_space.dtype)
    observation = core.observe(core.snapshot(), out)
    assert observation is not out
    assert (out == -1.0).all()


def test_a_batch_in_one_process_draws_each_observation_into_its_row(monkeypatch):
    """No env's observation is copied into the batch's rows on a step without autoresets;
    the rows hold each env's own view (an env stepped alone with the same seed and actions)."""
    writes = []
    original = envslice.EnvSlice._write
    monkeypatch.setattr(
        envslice.EnvSlice, "_write", lambda self, j, o: (writes.append(j), original(self, j, o))
    )
    batch = make_batch("tinyrace/CarRacing-v0", 3, workers=0)
    alone = [gym.make("tinyrace/CarRacing-v0") for _ in range(3)]
    batch.reset(seed=7)
    for index, env in enumerate(alone):
        env.reset(seed=7 + index)
    actions = np.array([[0.2, 0.5, 0.0], [-0.4, 0.3, 0.1], [0.0, 1.0, 0.0]], np.float32)
    for _ in range(3):  # the first step goes through the env checkers' own step
        batch.step(actions)
        expected = [env.step(action)[0] for env, action in zip(alone, actions, strict=True)]
    writes.clear()
    for _ in range(5):
        observations = batch.step(actions)[0]
        expected = [env.step(action)[0] for env, action in zip(alone, actions, strict=True)]
        np.testing.assert_array_equal(observations, np.stack(expected))
    assert writes == []
    batch.close()


def test_textures_share_one_warp_scratch_per_size():
    """Two textures warped to one size in one thread use one 4-channel scratch, and each
    warp's pixels stay its own texture's."""
    image = np.zeros((128, 128, 4), np.uint8)
    image[..., 0] = np.arange(128, dtype=np.uint8)[None, :]
    other = image.copy()
    other[..., 1] = 200
    a, b = texture.GroundTexture.from_image(image), texture.GroundTexture.from_image(other)
    matrix = np.array([[0.5, 0.1, 3.0], [-0.1, 0.5, 7.0]])
    alone = a.warp(matrix, (31, 17))
    texture._SCRATCH.clear()
    first = a.warp(matrix, (31, 17))
    second = b.warp(matrix, (31, 17))
    assert len(texture._SCRATCH) == 1
    np.testing.assert_array_equal(first, alone)
    np.testing.assert_array_equal(second[..., 0], first[..., 0])
    assert (second[..., 1] > 0).any() and not first[..., 1].any()
