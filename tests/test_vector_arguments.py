"""Bad arguments to the vector env and its asynchronous pool: each gets an error that names
the argument, the value and what is allowed, before any worker starts where it can; the
vector env stays usable after a bad call, and a constructor that fails leaves nothing
behind to report (no "Exception ignored in __del__")."""

from __future__ import annotations

import gc
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ClosedEnvironmentError
from vector_doubles import Quiet

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.errors import ConfigError
from tinyrace.vector import BatchVectorEnv, make_batch
from tinyrace.vector.pool import AsyncBatch

ID = "tinyrace/CarRacing-v0"


@pytest.fixture
def unraisable(monkeypatch) -> list[str]:
    """What Python reports as "Exception ignored in ..." while the test runs."""
    seen: list[str] = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: seen.append(repr(u.exc_value)))
    return seen


@pytest.mark.parametrize(
    ("make", "raised"),
    [
        (lambda: gym.make_vec(ID, 2, vectorization_mode="vector_entry_point", bogus=1), TypeError),
        (lambda: make_batch(ID, 2, 0, lap_complete_percent=5), ConfigError),
        (lambda: BatchVectorEnv([lambda: 42], workers=0), TypeError),
        (lambda: BatchVectorEnv([5, 6], workers=0), ConfigError),
    ],
)
def test_a_constructor_that_fails_leaves_no_error_to_ignore(unraisable, make, raised):
    with pytest.raises(raised):
        make()
    gc.collect()
    assert unraisable == []


@pytest.mark.parametrize(
    ("name", "value", "allowed"),
    [
        ("context", "bogus", "'spawn'"),
        ("copy", "no", "true or false"),
        ("batch_physics", "no", "true or false"),
        ("numpy_from", 0, "from 1 to"),
        ("numpy_from", "x", "from 1 to"),
        ("cores", [0, 0], "each core once"),
    ],
)
def test_a_bad_argument_is_named_before_any_worker_starts(name, value, allowed, unraisable):
    with pytest.raises(ConfigError) as caught:
        make_batch(ID, 2, 2, **{name: value})
    said = str(caught.value)
    assert f"{name}: got {value!r}" in said and allowed in said
    gc.collect()
    assert unraisable == []


def test_env_fns_that_are_not_functions_or_make_no_env_are_named():
    with pytest.raises(ConfigError, match=r"env_fns\[1\]: got 'x'"):
        BatchVectorEnv([lambda: Quiet(), "x"], workers=0)
    with pytest.raises(ConfigError, match="env_fns: got 'ab'"):
        BatchVectorEnv("ab", workers=0)
    with pytest.raises(TypeError, match=r"env_fns\[0\] .* returned 42, not a gymnasium.Env"):
        BatchVectorEnv([lambda: 42], workers=0)


@pytest.fixture
def local() -> BatchVectorEnv:
    vector = BatchVectorEnv([Quiet] * 2, workers=0)
    yield vector
    vector.close()


@pytest.mark.parametrize(
    ("call", "raised", "said"),
    [
        (lambda v: v.reset(seed=2.5), TypeError, "seed: expected None, a whole number"),
        (lambda v: v.reset(seed="ab"), TypeError, "got 'ab'"),
        (lambda v: v.reset(options=5), TypeError, "options: expected a dict or None, got 5"),
        (lambda v: v.step(None), ValueError, "expected actions for 2 envs, got a single value"),
        (lambda v: v.step([[0.0], [0.0, 1.0]]), ValueError, "actions: expected one per env"),
        (lambda v: v.call_at([5], "reset"), ValueError, "indices: got [5]; expected env"),
        (lambda v: v.set_attr_at([0.5], "t", 1), ValueError, "indices: got [0.5]"),
    ],
)
def test_a_bad_call_is_named_and_the_vector_env_stays_usable(local, call, raised, said):
    local.reset(seed=3)
    with pytest.raises(raised) as caught:
        call(local)
    assert said in str(caught.value)
    observations, *_ = local.step(np.zeros((2, 1), np.float32))
    assert observations.shape == (2, 2)


@pytest.mark.parametrize(("given", "same"), [(np.int64(7), 7), (np.arange(7, 9), [7, 8])])
def test_numpy_integer_seeds_seed_as_the_same_ints(local, given, same):
    other = BatchVectorEnv([Quiet] * 2, workers=0)
    try:
        local.reset(seed=given)
        other.reset(seed=same)
        actions = np.zeros((2, 1), np.float32)
        for _ in range(5):
            assert np.array_equal(local.step(actions)[0], other.step(actions)[0])
    finally:
        other.close()


@pytest.fixture
def pool() -> AsyncBatch:
    batch = AsyncBatch(BatchVectorEnv([Quiet] * 4, workers=2), batch_size=2)
    batch.reset(seed=0)
    yield batch
    batch.close()


@pytest.mark.parametrize("size", ["2", 2.5, 0, 5])
def test_a_pool_names_a_bad_batch_size(size):
    vector = BatchVectorEnv([Quiet] * 4, workers=2)
    try:
        with pytest.raises(ConfigError, match=f"batch_size: got {size!r}; expected a whole"):
            AsyncBatch(vector, batch_size=size)
    finally:
        vector.close()


@pytest.mark.parametrize(
    ("ids", "rows", "said"),
    [
        ([7, 8], 2, "env_ids: got [7, 8]; expected env ids (whole numbers) from 0 to 3"),
        ([0.5, 1.7], 2, "env_ids: got [0.5, 1.7]"),
        ([], 0, "env_ids: got []"),
        ([0, 1], 3, "actions: expected shape (2, 1)"),
        ([0, 1], 1, "got shape (1, 1)"),
    ],
)
def test_a_pool_names_bad_env_ids_and_actions_and_sends_nothing(pool, ids, rows, said):
    with pytest.raises(ValueError) as caught:
        pool.send(np.zeros((rows, 1), np.float32), ids)
    assert said in str(caught.value)
    assert pool.in_flight == []
    pool.send(np.zeros((4, 1), np.float32), np.arange(4))  # still usable
    assert sorted(pool.recv()[4]["env_id"].tolist() + pool.recv()[4]["env_id"].tolist()) == [
        0,
        1,
        2,
        3,
    ]


def test_a_closed_pool_says_so(pool):
    pool.close()
    with pytest.raises(ClosedEnvironmentError):
        pool.send(np.zeros((4, 1), np.float32), np.arange(4))
    with pytest.raises(ClosedEnvironmentError):
        pool.recv()
