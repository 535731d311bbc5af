"""Batched physics: many dynamic cars' tyre forces as one numpy computation, same results.

``DynamicBatch`` against ``DynamicCar.apply_forces`` car by car (random states, grass,
brakes, steering: velocities, spins and steering bit for bit). The in-process
``BatchVectorEnv`` (``workers=0``, batched physics) against ``SyncVectorEnv`` over the
same seeds and actions, bit for bit: observations, rewards, terminations,
truncations and infos, for 400 steps across autoresets (TimeLimit), full-throttle
stretches that leave the road for the grass, locked brakes that draw skid marks, a
``reset`` with a mask, on CarRacing-v0 (Box and Discrete actions) and on the metric
F1TENTH corridor with the dynamic car (walls stop it); and with fewer envs than
``numpy_from``, each car's own tyre model in the same split step.
"""

from __future__ import annotations

import functools
import math

import gymnasium as gym
import numpy as np
import pymunk
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.cars.dynamic import DynamicCar
from tinyrace.cars.dynamic_batch import DynamicBatch
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.vector import BatchVectorEnv, make_batch
from tinyrace.vector.batched import BatchStepper

DT = 1 / 50  # [s]


def assert_same(a, b, where: str = "") -> None:
    """Equal values of equal types: dicts key by key (in order), arrays by dtype and bits."""
    assert type(a) is type(b), (where, type(a), type(b))
    if isinstance(a, dict):
        assert list(a) == list(b), (where, list(a), list(b))
        for key in a:
            assert_same(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, np.ndarray):
        assert (a.dtype, a.shape) == (b.dtype, b.shape), where
        if a.dtype == object:
            for index, (x, y) in enumerate(zip(a, b, strict=True)):
                assert_same(x, y, f"{where}[{index}]")
        else:
            assert a.tobytes() == b.tobytes(), where
    elif isinstance(a, tuple | list):
        assert len(a) == len(b), where
        for index, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{where}[{index}]")
    elif isinstance(a, float):
        assert a == b or (math.isnan(a) and math.isnan(b)), (where, a, b)
        assert math.copysign(1, a) == math.copysign(1, b), (where, a, b)
    else:
        assert a == b, (where, a, b)


# -- the numpy model against the scalar one ------------------------------------------------------
def random_car(rng: np.random.Generator, scale: float, y_down: bool) -> DynamicCar:
    space = pymunk.Space()
    pose = (rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-4, 4))
    car = DynamicCar.build(space, pose, scale=scale, y_down=y_down)
    car.body.velocity = tuple(rng.normal(0, 70 * scale, 2))  # some beyond the speed cap
    car.body.angular_velocity = float(rng.normal(0, 2))
    for wheel in car.wheels:
        wheel.omega = float(rng.choice([0.0, rng.normal(0, 80)]))
        wheel.gas = float(rng.uniform(0, 1))
    for wheel in car.wheels[:2]:
        wheel.steer = float(rng.choice([0.0, rng.uniform(-0.4, 0.4)]))
    return car


def car_numbers(car: DynamicCar) -> list[float]:
    body = car.body
    numbers = [*body.velocity, body.angular_velocity, car.steer_target]
    for wheel in car.wheels:
        numbers += [wheel.omega, wheel.steer, wheel.gas, wheel.brake, wheel.phase, wheel.skidding]
    return numbers


@pytest.mark.parametrize("scale, y_down", [(1.0, False), (7.5, True)])
def test_batch_forces_equal_the_scalar_path_bit_for_bit(scale: float, y_down: bool) -> None:
    rng = np.random.default_rng(5)
    size, steps = 12, 30
    scalar = [random_car(np.random.default_rng(i), scale, y_down) for i in range(size)]
    batched = [random_car(np.random.default_rng(i), scale, y_down) for i in range(size)]
    batch = DynamicBatch(size)
    for row, car in enumerate(batched):
        batch.load(row, car)
    rows = list(range(size))
    capped = skidded = 0
    for _ in range(steps):
        steer = rng.uniform(-1, 1, size)
        gas = rng.choice([0.0, 1.0, 0.5, 1.5, -0.5], size)  # out of range: clipped as control()
        brake = rng.choice([0.0, 0.0, 0.3, 0.95], size)  # 0.95 locks the wheels
        on_road = rng.random((size, 4)) < 0.6
        for row, car in enumerate(scalar):
            car.control(float(steer[row]), float(gas[row]), float(brake[row]))
            car.apply_forces(DT, on_road[row].tolist())
        batch.control(steer, gas, brake)
        batch.apply_forces(np.full(size, DT), rows, on_road)
        batch.store(rows)
        batch.track_skids(rows, on_road)
        for row in rows:
            assert_same(car_numbers(batched[row]), car_numbers(scalar[row]), f"car {row}")
            skids_a, skids_b = batched[row].skids, scalar[row].skids
            assert skids_a.lengths.tolist() == skids_b.lengths.tolist()
            assert skids_a.points.tobytes() == skids_b.points.tobytes()
        skidded += int(batch.skidding.sum())
        cap = 2.0 * scale / DT  # [track units/s] Box2D's speed cap
        capped += sum(abs(abs(c.body.velocity) - cap) < 1e-9 * cap for c in scalar)
        for car in (*scalar, *batched):  # the bodies move as a space step would
            car.body.position += car.body.velocity * DT
            car.body.angle += car.body.angular_velocity * DT
    assert skidded > 0  # the grip limit and the skid marks were exercised
    assert capped > 0  # and the speed cap


def test_crash_stop_reaches_the_arrays() -> None:
    car = random_car(np.random.default_rng(1), 1.0, False)
    batch = DynamicBatch(1)
    batch.load(0, car)
    car.stop()
    batch.stop(0)
    assert batch.wheels(batch.omega, 0).tolist() == [w.omega for w in car.wheels] == [0.0] * 4


# -- the vector env against SyncVectorEnv --------------------------------------------------------
def driving_actions(space: gym.Space, num_envs: int, steps: int, seed: int) -> list[np.ndarray]:
    """Random actions with full-throttle stretches (the cars leave the road) and locked
    brakes (skid marks), for Box actions; Discrete ones are sampled."""
    space.seed(seed)
    rng = np.random.default_rng(seed)
    actions = []
    for step in range(steps):
        action = space.sample()
        if isinstance(space, gym.spaces.Box):
            phase = step % 60
            if phase == 0:
                turn = rng.uniform(-0.7, 0.7, num_envs)  # [steer] of this stretch
            if phase < 35:  # full gas in a curve: off the road onto the grass
                action[:, 0], action[:, 1], action[:, 2] = turn, 1.0, 0.0
            elif phase < 45:  # locked brakes at speed
                action[:, 1:] = (0.0, 1.0)
        actions.append(action)
    return actions


def compare(
    make: functools.partial, num_envs: int, steps: int, seed: int = 7, numpy_from: int = 1
) -> dict:
    """Steps a SyncVectorEnv and an in-process batched BatchVectorEnv in lock step; every
    result equal. Returns counts of what happened."""
    sync = gym.vector.SyncVectorEnv([make] * num_envs)
    batch = BatchVectorEnv([make] * num_envs, workers=0, numpy_from=numpy_from)
    assert batch._local is not None and batch._local.batch is not None  # batched physics
    assert batch._local.batch.vectorized == (num_envs >= numpy_from)
    seen = {"ends": 0, "grass": 0, "skids": 0, "walls": 0}
    try:
        assert_same(sync.reset(seed=seed), batch.reset(seed=seed), "reset")
        for step, action in enumerate(driving_actions(sync.action_space, num_envs, steps, seed)):
            if step == steps // 2:  # some envs reset by hand, with options
                mask = np.arange(num_envs) % 2 == 0
                options = {"reset_mask": mask}
                assert_same(sync.reset(options=dict(options)), batch.reset(options=options))
            expected, got = sync.step(action), batch.step(action)
            assert_same(expected, got, f"step {step}")
            info = expected[4]
            seen["ends"] += int((expected[2] | expected[3]).sum())
            seen["grass"] += int(info.get("wheels_on_grass", np.zeros(1)).sum())
            seen["walls"] += int(info.get("walls_hit", np.zeros(1)).sum())
        cars = [env.unwrapped.car for env in batch._local.envs]
        seen["skids"] = sum(int(car.skids.lengths.sum()) for car in cars)
        for env, twin in zip(sync.envs, batch._local.envs, strict=True):
            assert (
                env.unwrapped.car.skids.points.tobytes()
                == twin.unwrapped.car.skids.points.tobytes()
            )
    finally:
        sync.close()
        batch.close()
    return seen


def test_carracing_batched_equals_sync_vector_env() -> None:
    make = functools.partial(gym.make, "tinyrace/CarRacing-v0", max_episode_steps=90)
    seen = compare(make, num_envs=4, steps=400)
    assert seen["ends"] >= 16  # TimeLimit truncations, each followed by an autoreset
    assert seen["grass"] > 0  # wheels left the road
    assert seen["skids"] > 0  # skid marks were drawn


def test_carracing_discrete_batched_equals_sync_vector_env() -> None:
    make = functools.partial(
        gym.make, "tinyrace/CarRacing-v0", continuous=False, max_episode_steps=70
    )
    seen = compare(make, num_envs=3, steps=200)
    assert seen["ends"] >= 6


def test_few_cars_stepped_together_with_their_own_tyre_model_equal_sync() -> None:
    make = functools.partial(gym.make, "tinyrace/CarRacing-v0", max_episode_steps=70)
    seen = compare(make, num_envs=3, steps=200, numpy_from=4)
    assert seen["ends"] >= 6


def test_metric_track_with_dynamic_car_and_walls_equals_sync_vector_env() -> None:
    make = functools.partial(
        gym.make,
        "tinyrace/TinyRace-v0",
        environment=str(TRACKS_DIR / "f1tenth_loop"),
        car={"model": "dynamic"},
        sim={"step_limit": 150},
    )
    seen = compare(make, num_envs=3, steps=300)
    assert seen["walls"] > 0  # a car ran into a wall: stopped, in the arrays too
    assert seen["ends"] >= 3


def test_only_dynamic_cars_in_known_wrappers_are_batched() -> None:
    kinematic = functools.partial(
        gym.make, "tinyrace/TinyRace-v0", environment=str(TRACKS_DIR / "circuit")
    )
    clipped = functools.partial(
        lambda: gym.wrappers.ClipReward(gym.make("tinyrace/CarRacing-v0"), 0.0, 1.0)
    )
    assert BatchStepper.fits([gym.make("tinyrace/CarRacing-v0")])
    assert not BatchStepper.fits([kinematic()])
    assert not BatchStepper.fits([clipped()])
    envs = make_batch("tinyrace/CarRacing-v0", 2, workers=0, batch_physics=False)
    assert envs._local is not None and envs._local.batch is None
    envs.close()


def test_a_slice_of_one_env_steps_by_its_own_step() -> None:
    """One env alone costs more through the batched stages than by its own step: a
    process with one env steps it alone, with two it batches them; results equal."""
    make = functools.partial(gym.make, "tinyrace/CarRacing-v0")
    alone, pair = BatchVectorEnv([make], workers=0), BatchVectorEnv([make] * 2, workers=0)
    sync = gym.vector.SyncVectorEnv([make])
    try:
        assert alone._local is not None and alone._local.batch is None
        assert pair._local is not None and pair._local.batch is not None
        assert_same(sync.reset(seed=5), alone.reset(seed=5), "reset")
        for step, action in enumerate(driving_actions(sync.action_space, 1, 150, seed=5)):
            assert_same(sync.step(action), alone.step(action), f"step {step}")
    finally:
        for env in (alone, pair, sync):
            env.close()


class ShapingThatFails:
    """A user's cte shaping that returns NaN at its ``fail_at``-th call (a ConfigError)."""

    def __init__(self, fail_at: int | None) -> None:
        self.fail_at, self.calls = fail_at, 0

    def __call__(self, cte: float) -> float:
        self.calls += 1
        return math.nan if self.calls == self.fail_at else -abs(cte)


def test_an_env_whose_rewards_fail_leaves_the_others_of_its_batch_consistent() -> None:
    """Envs stepped together go stage by stage (every world, then every env's rewards, ...):
    when one env's reward shaping raises, every other env has still been judged, and each
    is where the same env stepped alone with the same actions is."""

    def make(fail_at: int | None) -> gym.Env:
        return gym.make(
            "tinyrace/TinyRace-v0",
            environment=str(TRACKS_DIR / "f1tenth_loop"),
            car={"model": "dynamic"},
            cte_shaping=ShapingThatFails(fail_at),
        )

    fns = [functools.partial(make, None), functools.partial(make, 6), functools.partial(make, None)]
    batch = BatchVectorEnv(fns, workers=0)
    alone = [fn() for fn in fns[::2]]  # twins of envs 0 and 2
    assert batch._local is not None and batch._local.batch is not None
    try:
        batch.reset(seed=3)
        for index, twin in zip((0, 2), alone, strict=True):
            twin.reset(seed=3 + index)
        actions = driving_actions(batch.action_space, 3, 10, seed=3)
        with pytest.raises(ConfigError, match="cte_shaping"):
            for action in actions:
                batch.step(action)
                for index, twin in zip((0, 2), alone, strict=True):
                    twin.step(action[index])
        for index, twin in zip((0, 2), alone, strict=True):  # the failing step's share too
            twin.step(action[index])
        for index, twin in zip((0, 2), alone, strict=True):
            env = batch._local.envs[index].unwrapped
            assert (env.steps, env.score) == (twin.unwrapped.steps, twin.unwrapped.score)
            ours, theirs = env.snapshot().car, twin.unwrapped.snapshot().car
            assert ours._replace(skids=None) == theirs._replace(skids=None)  # views: no ==
        # its shaping ran at 5 steps (a reset asks no shaping); the 6th step raised (counted,
        # as env.step counts it)
        assert batch._local.envs[1].unwrapped.steps == 6
    finally:
        batch.close()
        for twin in alone:
            twin.close()
