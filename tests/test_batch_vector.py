"""tinyrace.vector.BatchVectorEnv: several envs per worker process, SyncVectorEnv's results.

Every observation, reward, termination, truncation and info (with its ``_key``
masks) equals a SyncVectorEnv's with the same seeds and actions, across
autoresets, on the procedural track (Box observations) and on an image track
with two cameras (Dict observations): 150 steps with 3 envs in 2 workers, 50
steps with one worker. Also: spaces, reset seeds, options and masks, render,
closing, make_batch with spawned workers, errors raised in workers, a worker
that dies.
"""

from __future__ import annotations

import functools
import gc
import multiprocessing
import os
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ClosedEnvironmentError, InvalidAction
from gymnasium.vector.utils import batch_space
from vector_doubles import Still

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.vector import BatchVectorEnv, make_batch

ROOT = Path(__file__).resolve().parents[1]
EPISODE = 40  # [steps] so that 150 steps cross several autoresets
CAMERAS = [
    {"id": "front", "resolution": [60, 80], "roi": [360, 480]},
    {"id": "rear", "resolution": [60, 80], "roi": [360, 480], "yaw": 180},
]
FACTORIES = {
    "procedural": functools.partial(gym.make, "tinyrace/CarRacing-v0", max_episode_steps=EPISODE),
    "image_two_cameras": functools.partial(
        gym.make,
        "tinyrace/TinyRace-v0",
        environment=str(TRACKS_DIR / "formula_student"),
        cameras=CAMERAS,
        sim={"step_limit": EPISODE},
    ),
}
# (num_envs, workers, steps): 150 steps cross three autoresets, 50 steps one; 0 workers:
# every env in this process
LAYOUTS = {
    "3_envs_2_workers": (3, 2, 150),
    "2_envs_1_worker": (2, 1, 50),
    "3_envs_in_process": (3, 0, 150),
}


def assert_same(a, b, where: str = "") -> None:
    """Equal values of equal types: dicts key by key, arrays by dtype, shape, content and
    whether a caller may write into them."""
    assert type(a) is type(b), (where, type(a), type(b))
    if isinstance(a, tuple | list):
        assert len(a) == len(b), where
        for index, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{where}[{index}]")
    elif isinstance(a, dict):
        assert list(a) == list(b), (where, list(a), list(b))
        for key in a:
            assert_same(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, np.ndarray):
        assert (a.dtype, a.shape) == (b.dtype, b.shape), (where, a.dtype, b.dtype)
        assert a.flags.writeable == b.flags.writeable, (where, "writeable")
        if a.dtype == object:  # tuples, lists, None: compared one by one
            assert all(x == y for x, y in zip(a.ravel(), b.ravel(), strict=True)), where
        else:
            assert np.array_equal(a, b), where
    else:
        assert a == b, (where, a, b)


def run(vector: gym.vector.VectorEnv, steps: int = 150) -> list[tuple]:
    """reset(seed=5) and ``steps`` steps of seeded random actions; every output, then close."""
    history = [vector.reset(seed=5)]
    space = batch_space(vector.single_action_space, vector.num_envs)
    space.seed(7)
    for _ in range(steps):
        history.append(vector.step(space.sample()))
    vector.close()
    return history


@pytest.mark.parametrize("layout", list(LAYOUTS))
@pytest.mark.parametrize("kind", list(FACTORIES))
def test_matches_sync_vector_env(kind, layout):
    num_envs, workers, steps = LAYOUTS[layout]
    fns = [FACTORIES[kind]] * num_envs
    expected = run(gym.vector.SyncVectorEnv(fns), steps)
    got = run(BatchVectorEnv(fns, workers=workers), steps)
    for step, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert len(a) == len(b)
        for name, x, y in zip(("obs", "reward", "term", "trunc", "info"), a, b, strict=False):
            assert_same(x, y, f"step {step} {name}")
    # the run crossed autoresets: an episode end, then a step that resets (reward 0)
    ends = [(t, i) for t, out in enumerate(got[1:-1], 1) for i in np.flatnonzero(out[2] | out[3])]
    assert len(ends) >= num_envs * (steps // EPISODE)
    assert all(got[t + 1][1][i] == 0.0 and not (got[t + 1][2] | got[t + 1][3])[i] for t, i in ends)


def test_spaces_and_metadata():
    vector = BatchVectorEnv([FACTORIES["image_two_cameras"]] * 3, workers=2)
    single = FACTORIES["image_two_cameras"]()
    assert vector.num_envs == 3
    assert vector.single_observation_space == single.observation_space
    assert vector.single_action_space == single.action_space
    assert vector.observation_space == batch_space(single.observation_space, 3)
    assert vector.action_space == batch_space(single.action_space, 3)
    assert vector.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    observations, _ = vector.reset(seed=0)
    assert vector.observation_space.contains(observations)
    vector.close()


def test_reset_seeds_options_and_mask():
    fns = [FACTORIES["procedural"]] * 3
    sync, batch = gym.vector.SyncVectorEnv(fns), BatchVectorEnv(fns, workers=2)
    for seed in (3, [9, None, 4]):
        assert_same(sync.reset(seed=seed)[0], batch.reset(seed=seed)[0])
    assert batch.np_random_seed[0] == 9 and batch.np_random_seed[2] == 4
    options = {"randomize": False}
    assert_same(sync.reset(seed=1, options=options), batch.reset(seed=1, options=options))
    mask = np.array([False, True, False])
    before = batch.step(np.zeros((3, 3), np.float32))[0]
    sync.step(np.zeros((3, 3), np.float32))
    sync_mask = {"reset_mask": mask}
    observations, infos = batch.reset(seed=[0, 2, 0], options={"reset_mask": mask})
    assert_same(sync.reset(seed=[0, 2, 0], options=sync_mask), (observations, infos))
    assert np.array_equal(observations[[0, 2]], before[[0, 2]])  # not reset
    assert list(infos["_speed"]) == [False, True, False]
    with pytest.raises(ValueError, match="length must match num_envs=3"):
        batch.reset(seed=[1, 2])
    with pytest.raises(ValueError, match="reset_mask"):
        batch.reset(options={"reset_mask": np.zeros(3, np.bool_)})
    sync.close()
    batch.close()


def test_render_returns_every_envs_frame():
    fns = [functools.partial(gym.make, "tinyrace/CarRacing-v0", render_mode="rgb_array")] * 2
    sync, batch = gym.vector.SyncVectorEnv(fns), BatchVectorEnv(fns, workers=2)
    sync.reset(seed=0)
    batch.reset(seed=0)
    frames = batch.render()
    assert isinstance(frames, tuple) and len(frames) == 2 and frames[0].shape == (400, 600, 3)
    assert_same(frames, sync.render())
    sync.close()
    batch.close()


def test_close_twice_ends_the_workers():
    vector = make_batch("tinyrace/CarRacing-v0", 3, workers=2)
    vector.reset(seed=0)
    processes = list(vector._workers.processes)
    assert len(processes) == 2 and all(p.is_alive() for p in processes)
    vector.close()
    vector.close()
    assert vector.closed and not any(p.is_alive() for p in processes)
    assert all(p.exitcode == 0 for p in processes)  # closed, not terminated
    with pytest.raises(ClosedEnvironmentError):
        vector.step(vector.action_space.sample())


def test_make_batch_with_spawned_workers():
    """Spawned workers import tinyrace (and register its ids) to make the envs."""
    kwargs = {"max_episode_steps": EPISODE}
    vector = make_batch("tinyrace/CarRacing-v0", 2, workers=1, context="spawn", **kwargs)
    expected = run(gym.vector.SyncVectorEnv([FACTORIES["procedural"]] * 2), steps=3)
    for a, b in zip(expected, run(vector, steps=3), strict=True):
        assert_same(a[0], b[0])


# -- errors in the workers -------------------------------------------------------------------
class Fragile(Still):
    """Raises ValueError on an action > 0.5, exits its process on an action < -0.5."""

    def step(self, action):
        if action[0] > 0.5:
            raise ValueError(f"fragile env refused action {action[0]:.1f}")
        if action[0] < -0.5:
            os._exit(3)
        return np.full(2, 0.5, np.float32), 1.0, False, False, {}


class Counter(gym.Env):
    """Counts its steps: a Discrete and a Box in a Dict, not only Boxes."""

    observation_space = gym.spaces.Dict(
        {"count": gym.spaces.Discrete(100), "half": gym.spaces.Box(0.0, 50.0, (1,), np.float64)}
    )
    action_space = gym.spaces.Discrete(2)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.count = int(self.np_random.integers(10))
        return self._observe(), {"start": self.count}

    def step(self, action):
        self.count += 1 + int(action)
        return self._observe(), float(self.count), self.count >= 20, False, {}

    def _observe(self):
        return {"count": self.count, "half": np.array([self.count / 2])}


def test_other_observation_spaces():
    expected = run(gym.vector.SyncVectorEnv([Counter] * 3), steps=30)
    got = run(BatchVectorEnv([Counter] * 3, workers=2), steps=30)
    for step, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert_same(a, b, f"step {step}")


def test_more_workers_than_envs():
    vector = BatchVectorEnv([Fragile] * 2, workers=4)
    assert len(vector._workers.processes) == 2
    vector.reset(seed=0)
    assert vector.step(np.zeros((2, 1), np.float32))[1].tolist() == [1.0, 1.0]
    vector.close()


def test_worker_exception_is_raised_in_the_parent():
    vector = BatchVectorEnv([Fragile] * 3, workers=2)
    vector.reset(seed=0)
    with pytest.raises(ValueError, match=r"refused action 0\.9") as raised:
        vector.step(np.array([[0.0], [0.0], [0.9]], np.float32))
    note = "\n".join(raised.value.__notes__)
    assert "worker 1 (envs 1-2)" in note and "Traceback" in note and "in step" in note
    observations, rewards, *_ = vector.step(np.zeros((3, 1), np.float32))  # still usable
    assert rewards.tolist() == [1.0, 1.0, 1.0] and observations.shape == (3, 2)
    vector.close()


def test_tinyrace_errors_name_their_cause():
    vector = BatchVectorEnv([FACTORIES["procedural"]] * 2, workers=2)
    vector.reset(seed=0)
    with pytest.raises(InvalidAction):
        vector.step(np.array([[0.0, 0.5, 0.0], [np.nan, 0.5, 0.0]], np.float32))
    with pytest.raises(ConfigError) as raised:  # pickled by its problems across processes
        vector.reset(options={"nope": 1})
    (problem,) = raised.value.problems
    assert problem.path == "nope" and "unknown option" in str(raised.value)
    vector.close()


def test_env_that_cannot_be_made_in_a_worker():
    def broken() -> gym.Env:
        raise FileNotFoundError("no track here")

    before = set(multiprocessing.active_children())
    with pytest.raises(FileNotFoundError, match="no track here"):
        BatchVectorEnv([Fragile, Fragile, broken], workers=2)
    assert set(multiprocessing.active_children()) <= before  # the other worker was closed


def test_a_worker_that_dies():
    vector = BatchVectorEnv([Fragile] * 2, workers=2)
    vector.reset(seed=0)
    with pytest.raises(RuntimeError, match=r"worker 1 \(envs 1\) died .*exit code 3"):
        vector.step(np.array([[0.0], [-0.9]], np.float32))
    assert vector.closed
    vector.close()


def test_observations_are_written_in_one_copy_only_when_each_fits_its_row():
    """``_write_rows``: arrays of the rows' shape and dtype in one concatenation; anything
    else row by row as numpy assigns (cast, broadcast, or its error), never shifted rows."""
    from tinyrace.vector.envslice import _write_rows

    rows = np.zeros((2, 3, 2), np.uint8)
    _write_rows(rows, [np.full((3, 2), 1, np.uint8), np.full((3, 2), 2, np.uint8)])
    assert rows[:, :, 0].tolist() == [[1, 1, 1], [2, 2, 2]]
    _write_rows(rows, [np.full((3, 2), 7.9), [[3, 4]] * 3])  # float64 cast, a list
    assert rows[0].tolist() == [[7, 7]] * 3 and rows[1].tolist() == [[3, 4]] * 3
    _write_rows(rows, [np.uint8(5), np.full((1, 2), 6, np.uint8)])  # broadcast
    assert rows[0].tolist() == [[5, 5]] * 3 and rows[1].tolist() == [[6, 6]] * 3
    with pytest.raises(ValueError):  # 4 + 2 rows add up to the batch's 6: not one copy
        _write_rows(rows, [np.zeros((4, 2), np.uint8), np.zeros((2, 2), np.uint8)])
    assert rows[0].tolist() == [[5, 5]] * 3  # the first row was not overwritten in a shift


@pytest.mark.parametrize("context", ["fork", "spawn"])
def test_a_worker_freezes_what_it_inherits_so_its_collections_skip_it(context):
    """A forked worker inherits every object of its parent (here pytest's and the test
    session's): ``gc.freeze`` at its start keeps its collections from traversing them."""
    from vector_doubles import Collector

    if context not in multiprocessing.get_all_start_methods():
        pytest.skip(f"no {context} start method on this platform")
    vector = BatchVectorEnv([Collector] * 2, workers=2, context=context)
    try:
        frozen = vector.call("frozen")
        parent = gc.get_freeze_count()
        assert all(count > 1000 for count in frozen), frozen  # the imports at least
        assert parent == 0  # the parent's collections are left as they are
    finally:
        vector.close()


@pytest.mark.parametrize("context", ["fork", "spawn"])
def test_a_worker_freezes_what_its_first_reset_loaded_and_still_collects_later_garbage(context):
    """What an env loads at its first reset (tinyrace's kernels, numba with them) lives as
    long as the worker: frozen after that reset, the worker's collections skip it. Frozen
    once: later episodes' garbage (a cycle per reset here) is still collected."""
    from vector_doubles import Lazy

    if context not in multiprocessing.get_all_start_methods():
        pytest.skip(f"no {context} start method on this platform")
    vector = BatchVectorEnv([Lazy] * 2, workers=2, context=context)
    try:
        vector.reset(seed=0, options={"reset_mask": np.array([False, True])})
        vector.reset(seed=0)  # env 0's first reset: its worker's too
        first = vector.call("heap")
        for _ in range(10):
            vector.reset()
            vector.step(np.zeros((2, 1), np.float32))
        later = vector.call("heap")
        for (tracked, frozen, _), (tracked_later, frozen_later, collects) in zip(
            first, later, strict=True
        ):
            assert tracked < Lazy.LOADS // 2, first  # the loaded objects are not traversed
            assert frozen > Lazy.LOADS, first
            assert frozen_later <= frozen  # frozen once, not at every reset
            assert tracked_later < tracked + 1000, later  # 10 episodes' cycles collected
            assert collects  # by the collector itself, as before
        assert gc.get_freeze_count() == 0  # the parent's collections are left as they are
    finally:
        vector.close()
