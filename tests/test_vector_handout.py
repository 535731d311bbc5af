"""Observations handed out over the vector env's buffers (``tinyrace.vector.handout``).

With ``copy=True`` an array handed out never changes afterwards, whether the caller
keeps it, a view of it or a tensor over it, and whatever comes next (steps, resets with
a mask, ``AsyncBatch``); the common loop that drops the last batch gets no copies; results
equal SyncVectorEnv's while the buffers take turns.
"""

from __future__ import annotations

import gc

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector.utils import batch_space
from vector_doubles import Heavy

from tests.test_batch_vector import FACTORIES, assert_same
from tinyrace.vector import BatchVectorEnv, make_batch
from tinyrace.vector.handout import BUFFERS
from tinyrace.vector.pool import AsyncBatch

LAYOUTS = {"in_process": 0, "two_workers": 2}


def actions(vector: gym.vector.VectorEnv, steps: int, seed: int = 7) -> list:
    space = batch_space(vector.single_action_space, vector.num_envs)
    space.seed(seed)
    return [space.sample() for _ in range(steps)]


def leaves(observations) -> list[np.ndarray]:
    if isinstance(observations, dict):
        return [a for value in observations.values() for a in leaves(value)]
    return [observations]


def copied(observations):
    if isinstance(observations, dict):
        return {key: copied(value) for key, value in observations.items()}
    return observations.copy()


@pytest.mark.parametrize("workers", LAYOUTS.values(), ids=LAYOUTS.keys())
@pytest.mark.parametrize("kind", FACTORIES)
def test_the_common_loop_matches_sync_vector_env_without_copies(kind, workers):
    """obs dropped at each step: the buffers take turns (no array owns its data), and each
    step's results are SyncVectorEnv's."""
    sync = gym.vector.SyncVectorEnv([FACTORIES[kind]] * 3)
    batch = BatchVectorEnv([FACTORIES[kind]] * 3, workers=workers)
    try:
        expected, _ = sync.reset(seed=5)
        observations, _ = batch.reset(seed=5)
        assert_same(expected, observations)
        for step, action in enumerate(actions(sync, 60)):
            expected = sync.step(action)
            observations, *rest = batch.step(action)
            assert_same(expected, (observations, *rest), f"step {step}")
            if step > 2:
                assert all(not leaf.flags.owndata for leaf in leaves(observations))
    finally:
        sync.close()
        batch.close()


@pytest.mark.parametrize("workers", LAYOUTS.values(), ids=LAYOUTS.keys())
def test_held_arrays_and_views_never_change(workers):
    """Keep every fifth batch, a row view of others and a float tensor-like view: each still
    equals its copy 30 steps later; a caller that holds every buffer gets copies."""
    batch = make_batch("tinyrace/CarRacing-v0", 3, workers, max_episode_steps=25)
    try:
        observations, _ = batch.reset(seed=1)
        kept = [(observations, copied(observations))]
        for step, action in enumerate(actions(batch, 60)):
            observations = batch.step(action)[0]
            if step % 5 == 0:
                kept.append((observations, copied(observations)))
            elif step % 7 == 0:
                row = observations[2]  # only a view of one row stays
                kept.append((row, row.copy()))
            elif step % 11 == 0:
                strided = observations[:, ::2, 1:, 0].T
                kept.append((strided, strided.copy()))
        for index, (held, snapshot) in enumerate(kept):
            assert np.array_equal(held, snapshot), f"kept batch {index} changed"
        owned = [observations.flags.owndata for observations, _ in kept[-BUFFERS:]]
        assert any(owned)  # every buffer held: copies
    finally:
        batch.close()


def test_a_reset_with_a_mask_keeps_the_other_rows_while_the_last_batch_is_held():
    sync = gym.vector.SyncVectorEnv([FACTORIES["procedural"]] * 3)
    batch = BatchVectorEnv([FACTORIES["procedural"]] * 3, workers=2)
    try:
        held = [sync.reset(seed=2)[0], batch.reset(seed=2)[0]]
        for action in actions(sync, 5):
            held = [sync.step(action)[0], batch.step(action)[0]]
        snapshot = held[1].copy()
        mask = np.array([False, True, False])
        expected, expected_infos = sync.reset(seed=3, options={"reset_mask": mask})
        got, infos = batch.reset(seed=3, options={"reset_mask": mask})
        assert_same(expected, got)
        assert_same(expected_infos, infos)
        assert np.array_equal(held[1], snapshot)
        assert np.array_equal(got[[0, 2]], snapshot[[0, 2]])  # rows left as they were
    finally:
        sync.close()
        batch.close()


def test_async_batches_leave_the_reset_observations_alone():
    vector = make_batch("tinyrace/CarRacing-v0", 4, 2)
    pool = AsyncBatch(vector, batch_size=2)
    try:
        observations, _ = pool.reset(seed=0)
        snapshot = observations.copy()
        for action in actions(vector, 6):
            pool.send(action, np.arange(4))
            pool.recv()
            pool.recv()
        assert np.array_equal(observations, snapshot)
    finally:
        pool.close()


def test_a_small_batch_is_copied():
    """Under HAND_OUT_FROM bytes a copy costs less than a hand-out: one buffer, copies."""
    batch = make_batch("tinyrace/CarRacing-v0", 1, 1)
    try:
        assert len(batch._views.buffers) == 1
        observations, _ = batch.reset(seed=0)
        assert observations.flags.owndata
        assert batch.step(np.zeros((1, 3), np.float32))[0].flags.owndata
    finally:
        batch.close()


def test_the_buffers_are_freed_with_the_arrays_after_close():
    batch = make_batch("tinyrace/CarRacing-v0", 3, 1)
    observations, _ = batch.reset(seed=0)
    snapshot = observations.copy()
    batch.close()
    gc.collect()
    assert np.array_equal(observations, snapshot)  # still readable after close


@pytest.mark.parametrize("workers", LAYOUTS.values(), ids=LAYOUTS.keys())
def test_a_step_that_raises_leaves_the_failing_envs_last_observations(workers):
    """Env 2 raises while the last batch is held (the step writes another buffer): the
    rows of its worker (every row in process) keep the observations from before the step,
    never a buffer's older contents."""
    batch = BatchVectorEnv([Heavy] * 3, workers=workers)  # 2 workers: envs 0 | 1, 2
    try:
        held = [batch.reset(seed=0)[0]]
        for _ in range(3):
            held = [held[-1], batch.step(np.zeros((3, 1), np.float32))[0]]
        with pytest.raises(ValueError, match="heavy env refused"):
            batch.step(np.array([[0.0], [0.0], [0.9]], np.float32))
        mask = np.array([True, False, False])
        observations, _ = batch.reset(seed=1, options={"reset_mask": mask})
        assert np.all(observations[0] == 0)  # reset
        assert np.all(observations[1:] == 3), observations[1:, 0]  # as after step 3
    finally:
        batch.close()
