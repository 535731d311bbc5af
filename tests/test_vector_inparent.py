"""BatchVectorEnv with ``parent_steps=True``: the parent steps the last slice of the envs
itself, beside the worker processes (``tinyrace.vector.inparent``).

Every result equals SyncVectorEnv's, bit for bit, as without it: observations (Box and
Dict), rewards, flags, infos of every shape (records, new signatures, infos by "pipe"),
autoresets, step_async / step_wait, actions that go by pipe, reset masks, call and
set_attr. An exception of the parent's own envs is raised as it is, named, once every
worker has answered, and the vector env stays usable; Ctrl-C in the parent's slice
closes it; closing frees the shared memory and ends the workers; render and spawned
workers beside it; the entry points' default layout.
"""

from __future__ import annotations

import functools
import gc
import multiprocessing
import os
import subprocess
import sys

import cv2
import gymnasium as gym
import numpy as np
import pytest
from vector_doubles import Blinking, Chatty, Doomed, Flags, NumpyBool, Quiet, Still, Tiles

import tinyrace  # noqa: F401  (registers the env ids)
from tests.test_batch_vector import FACTORIES, Counter, Fragile, assert_same, run
from tests.test_vector_shared import _record_created, bounded, segments  # noqa: F401
from tinyrace.vector import BatchVectorEnv, make, make_batch
from tinyrace.vector.make import layout
from tinyrace.vector.pool import AsyncBatch

# (num_envs, workers, steps): the parent's slice is the last of workers + 1
LAYOUTS = {"3_envs_1_worker": (3, 1, 150), "5_envs_2_workers": (5, 2, 50)}


def compare(fns: list, workers: int, steps: int) -> list[tuple]:
    expected = run(gym.vector.SyncVectorEnv(fns), steps)
    batch = BatchVectorEnv(fns, workers=workers, parent_steps=True)
    assert batch._workers.parent is not None and len(batch._workers.processes) == workers
    got = run(batch, steps)
    for step, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert_same(a, b, f"step {step}")
    return got


@pytest.mark.parametrize("layout", list(LAYOUTS))
@pytest.mark.parametrize("kind", list(FACTORIES))
def test_matches_sync_vector_env(kind, layout):
    num_envs, workers, steps = LAYOUTS[layout]
    got = compare([FACTORIES[kind]] * num_envs, workers, steps)
    ends = [(t, i) for t, out in enumerate(got[1:-1], 1) for i in np.flatnonzero(out[2] | out[3])]
    assert any(i == num_envs - 1 for _, i in ends)  # the parent's env autoreset too


@pytest.mark.parametrize(
    "toy", [Chatty, Blinking, Tiles, Quiet, NumpyBool, Flags, Counter], ids=lambda t: t.__name__
)
def test_infos_and_spaces_of_every_kind_match_sync_vector_env(toy):
    """Infos that change shape, disagree within a slice, go by "pipe" (numpy bools),
    episode ends of any type, a Dict space."""
    compare([toy] * 4, 1, 60)


def test_actions_that_a_cast_would_change_go_by_pipe_and_step_async():
    fns = [FACTORIES["procedural"]] * 3
    sync, batch = gym.vector.SyncVectorEnv(fns), BatchVectorEnv(fns, 1, parent_steps=True)
    assert_same(sync.reset(seed=2), batch.reset(seed=2))
    actions = np.array([[0.1 + 1e-12, 0.5, 0.0], [-0.3, 0.2, 0.1], [0.2, 0.3, 0.0]], np.float64)
    for _ in range(3):
        assert_same(sync.step(actions), batch.step(actions))
    batch.step_async(actions.astype(np.float32))
    assert_same(sync.step(actions.astype(np.float32)), batch.step_wait())
    sync.close()
    batch.close()


def test_reset_mask_call_and_set_attr_reach_the_parents_envs():
    fns = [Fragile] * 3
    sync, batch = gym.vector.SyncVectorEnv(fns), BatchVectorEnv(fns, 1, parent_steps=True)
    for vector in (sync, batch):
        vector.reset(seed=0)
        vector.step(np.zeros((3, 1), np.float32))
        vector.set_attr("t", [5, 6, 7])
    mask = np.array([False, True, True])
    assert_same(sync.reset(options={"reset_mask": mask}), batch.reset(options={"reset_mask": mask}))
    assert batch.get_attr("t") == sync.get_attr("t") == (5, 0, 0)
    step = np.zeros(1, np.float32)
    picked = sync.call("step", step)
    assert_same(batch.call_at([0, 2], "step", step), (picked[0], picked[2]))
    sync.close()
    batch.close()


def test_an_exception_of_the_parents_envs_is_raised_as_it_is():
    vector = BatchVectorEnv([Fragile] * 3, workers=1, parent_steps=True)
    vector.reset(seed=0)
    with bounded(), pytest.raises(ValueError, match=r"refused action 0\.9") as raised:
        vector.step(np.array([[0.0], [0.0], [0.9]], np.float32))
    notes = "\n".join(raised.value.__notes__)
    assert "raised by env 2" in notes and "parent process (envs 1-2)" in notes
    assert raised.value.__traceback__ is not None  # the exception itself, not a copy
    observations, rewards, *_ = vector.step(np.zeros((3, 1), np.float32))  # still usable
    assert rewards.tolist() == [1.0, 1.0, 1.0] and observations.shape == (3, 2)
    with bounded(), pytest.raises(ValueError, match="refused"):  # a worker's and the parent's
        vector.step(np.array([[0.9], [0.0], [0.9]], np.float32))
    assert vector.step(np.zeros((3, 1), np.float32))[1].tolist() == [1.0] * 3
    vector.close()


class Interrupted(Fragile):
    """Ctrl-C in its step (as a KeyboardInterrupt arrives in the parent's slice)."""

    def step(self, action):
        if action[0] > 0.5:
            raise KeyboardInterrupt
        return super().step(action)


def test_ctrl_c_in_the_parents_slice_closes_the_vector_env():
    before, children = segments(), set(multiprocessing.active_children())
    vector = BatchVectorEnv([Interrupted] * 4, workers=1, parent_steps=True)
    vector.reset(seed=0)
    with bounded(), pytest.raises(KeyboardInterrupt):
        vector.step(np.array([[0.0], [0.0], [0.0], [0.9]], np.float32))
    assert vector.closed
    assert set(multiprocessing.active_children()) <= children  # no worker left
    assert segments() <= before


def test_a_dying_worker_beside_the_parents_slice_is_named():
    vector = BatchVectorEnv([Doomed] * 4, workers=1, parent_steps=True)
    vector.reset(seed=0)
    with bounded(), pytest.raises(RuntimeError, match=r"worker 0 \(envs 0-1\) died"):
        vector.step(np.array([[-0.9], [0.0], [0.0], [0.0]], np.float32))
    assert vector.closed


def test_closing_frees_the_memory_and_one_env_needs_no_process():
    before, children = segments(), set(multiprocessing.active_children())
    vector = make_batch("tinyrace/CarRacing-v0", 3, workers=2, parent_steps=True)
    assert len(vector._workers.processes) == 2  # 3 slices: two workers and the parent
    vector.reset(seed=0)
    vector.step(np.zeros((3, 3), np.float32))
    vector.close()
    assert segments() <= before and set(multiprocessing.active_children()) <= children
    single = BatchVectorEnv([Still], workers=3, parent_steps=True)
    assert single._local is not None and not single._workers.processes
    single.close()


def test_async_batch_refuses_a_parents_slice():
    vector = BatchVectorEnv([Still] * 4, workers=1, parent_steps=True)
    with pytest.raises(ValueError, match="parent_steps"):
        AsyncBatch(vector, batch_size=2)
    vector.close()


def test_the_entry_points_default_to_a_slice_per_core_the_parent_stepping_one(monkeypatch):
    monkeypatch.setattr(make, "usable_cores", lambda: 3)
    assert layout(8, None, None) == (2, True)  # 3 slices: 2 workers and the parent
    assert layout(2, None, None) == (1, True)
    assert layout(1, None, None) == (1, False)  # one env: one worker, as before
    assert layout(8, None, False) == (3, False)  # a worker process per core
    assert layout(8, 2, None) == (2, False) and layout(8, 2, True) == (2, True)
    envs = gym.make_vec("tinyrace/CarRacing-v0", num_envs=4)
    try:
        assert len(envs._workers.processes) == 2 and envs._workers.parent is not None
        assert envs.reset(seed=0)[0].shape == (4, 96, 96, 3)
    finally:
        envs.close()


def test_render_and_spawned_workers_beside_the_parents_slice():
    fns = [functools.partial(gym.make, "tinyrace/CarRacing-v0", render_mode="rgb_array")] * 3
    sync = gym.vector.SyncVectorEnv(fns)
    batch = BatchVectorEnv(fns, workers=1, context="spawn", parent_steps=True)
    assert_same(sync.reset(seed=0), batch.reset(seed=0))
    actions = np.tile(np.array([0.1, 0.6, 0.0], np.float32), (3, 1))
    assert_same(sync.step(actions), batch.step(actions))
    frames = batch.render()
    assert len(frames) == 3 and frames[2].shape == (400, 600, 3)
    assert_same(frames, sync.render())
    sync.close()
    batch.close()


class Threads(Fragile):
    """Reports OpenCV's thread count during its step in its info."""

    def step(self, action):
        observation, reward, terminated, truncated, _ = super().step(action)
        return observation, reward, terminated, truncated, {"threads": cv2.getNumThreads()}


def test_opencv_runs_on_one_thread_in_the_parents_step_only():
    before = cv2.getNumThreads()
    cv2.setNumThreads(2)
    try:
        vector = BatchVectorEnv([Threads] * 2, workers=1, parent_steps=True)
        vector.reset(seed=0)
        infos = vector.step(np.zeros((2, 1), np.float32))[4]
        assert infos["threads"][1] == 1  # env 1: the parent's
        assert cv2.getNumThreads() == 2  # as it was before the step
        vector.close()
    finally:
        cv2.setNumThreads(before)


@pytest.mark.parametrize("parent_steps", [False, True])
def test_a_forked_worker_runs_opencv_on_one_thread_and_the_parent_keeps_its_count(parent_steps):
    """The parent forks its workers with OpenCV at one thread: a forked worker never uses
    the thread pool it copied, whose threads it does not have."""
    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork start method on this platform")
    before = cv2.getNumThreads()
    cv2.setNumThreads(2)
    try:
        vector = BatchVectorEnv([Threads] * 2, workers=1, parent_steps=parent_steps, context="fork")
        assert cv2.getNumThreads() == 2  # as it was
        vector.reset(seed=0)
        infos = vector.step(np.zeros((2, 1), np.float32))[4]
        assert infos["threads"][0] == 1  # env 0: a forked worker's
        vector.close()
    finally:
        cv2.setNumThreads(before)


def test_the_parents_collector_is_left_alone_when_it_steps_a_slice():
    """A worker process freezes its heap after its first reset (``worker.settle``); the
    parent's slice, stepped in the user's process, must not freeze the user's heap."""
    from vector_doubles import Lazy

    before = gc.get_freeze_count()
    vector = BatchVectorEnv([Lazy] * 2, workers=1, parent_steps=True)
    try:
        vector.reset(seed=0)
        vector.step(np.zeros((2, 1), np.float32))
        vector.reset(seed=1)
        worker, _ = vector.call("heap")
        assert worker[1] > Lazy.LOADS  # the worker process froze what its reset loaded
        assert gc.get_freeze_count() == before  # this process froze nothing
    finally:
        vector.close()


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="no CPU affinity on this OS")
def test_the_default_layout_counts_the_cores_this_process_may_run_on():
    """A job given one core of a larger machine (taskset, a cpuset) gets one slice, not a
    worker per core of the machine; measured in a child process so this one's affinity
    stays as it was."""
    script = (
        "import os\n"
        "from tinyrace.vector.make import layout, usable_cores\n"
        "os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})\n"
        "print(usable_cores(), layout(8, None, None), layout(8, None, False))\n"
    )
    ran = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    assert ran.stdout.split("\n")[0] == "1 (1, False) (1, False)"
    assert make.usable_cores() == len(os.sched_getaffinity(0))
