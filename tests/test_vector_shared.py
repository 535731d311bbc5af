"""BatchVectorEnv's shared-memory step: infos by record and by exception, step_async and
step_wait, workers that die or raise (named, never a hang), the memory freed on close.

Every result is compared with SyncVectorEnv's, bit for bit (``assert_same``).
"""

from __future__ import annotations

import contextlib
import functools
import gc
import multiprocessing
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from multiprocessing import shared_memory, synchronize
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import AlreadyPendingCallError, NoAsyncCallError
from vector_doubles import Blinking, Chatty, Doomed

import tinyrace  # registers the env ids; its folder for the scripts run below
from tests.test_batch_vector import EPISODE, FACTORIES, assert_same, run
from tinyrace.vector import BatchVectorEnv, make_batch, shared
from tinyrace.vector.pool import AsyncBatch
from tinyrace.vector.records import (
    INFO_BYTES,
    flatten,
    merge_columns,
    record_dtype,
    record_struct,
    records,
)

SHM = Path("/dev/shm")
BOUND = 60  # [s] a test that waits longer has hung


@contextlib.contextmanager
def bounded(seconds: int = BOUND) -> Iterator[None]:
    """Fail (instead of hanging) if the block takes longer than ``seconds``."""

    def hung(signum: int, frame: object) -> None:
        raise TimeoutError(f"hung for {seconds} s")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


@pytest.mark.parametrize(("num_envs", "workers"), [(3, 2), (1, 1), (4, 1)])
def test_infos_of_every_shape_match_sync_vector_env(num_envs, workers):
    expected = run(gym.vector.SyncVectorEnv([Chatty] * num_envs), steps=80)
    got = run(BatchVectorEnv([Chatty] * num_envs, workers=workers), steps=80)
    for step, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert_same(a, b, f"step {step}")


@pytest.mark.parametrize(("num_envs", "workers"), [(1, 1), (3, 2)])
def test_infos_whose_shape_takes_turns_are_announced_once_per_shape(num_envs, workers):
    """A shape a worker has announced is named by its number afterwards: the parent keeps
    one entry per shape and worker, and the results stay SyncVectorEnv's."""
    expected = run(gym.vector.SyncVectorEnv([Blinking] * num_envs), steps=40)
    batch = BatchVectorEnv([Blinking] * num_envs, workers=workers)
    known = []
    close = batch.close

    def close_after_looking() -> None:  # run() closes it: look at the parent's table first
        known.extend(batch._answers.known)
        close()

    batch.close = close_after_looking  # type: ignore[method-assign]
    got = run(batch, steps=40)
    for step, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert_same(a, b, f"step {step}")
    assert len(known) == workers
    for announced in known:
        assert len(announced) == 3 == len(set(announced)), announced  # + the reset info


def test_records_round_trip_the_infos():
    info = {"pose": (1.5, -2.0), "n": 3, "ok": False, "x": np.float32(0.25), "d": {"a": 1.0}}
    signature, values = flatten(info)
    dtype = record_dtype(signature)
    infos = np.zeros((2, INFO_BYTES), np.uint8)
    for row in infos:
        record_struct(signature).pack_into(row, 0, *values)  # as a worker packs them
    merged = merge_columns(signature, records(infos, dtype))
    assert list(merged) == ["pose", "_pose", "n", "_n", "ok", "_ok", "x", "_x", "d", "_d"]
    assert merged["pose"][1] == (1.5, -2.0) and merged["x"].dtype == np.float32
    assert flatten({"s": "text"}) is None and flatten({"t": (1, 2)}) is None
    assert record_dtype(tuple((f"k{i}", tuple, 16) for i in range(4))) is not None  # 512 bytes
    assert record_dtype(tuple((f"k{i}", tuple, 16) for i in range(5))) is None  # 640 bytes


def test_actions_that_a_cast_would_change_go_by_pipe():
    """float64 actions reach the envs as float64, as in SyncVectorEnv."""
    fns = [FACTORIES["procedural"]] * 2
    sync, batch = gym.vector.SyncVectorEnv(fns), BatchVectorEnv(fns, workers=1)
    assert_same(sync.reset(seed=2), batch.reset(seed=2))
    actions = np.array([[0.1 + 1e-12, 0.5, 0.0], [-0.3, 0.2, 0.1]], np.float64)
    for _ in range(3):
        assert_same(sync.step(actions), batch.step(actions))
    sync.close()
    batch.close()


def test_step_async_and_step_wait():
    fns = [FACTORIES["procedural"]] * 3
    sync, batch = gym.vector.SyncVectorEnv(fns), BatchVectorEnv(fns, workers=2)
    assert_same(sync.reset(seed=4), batch.reset(seed=4))
    actions = np.tile(np.array([0.2, 0.6, 0.0], np.float32), (3, 1))
    with pytest.raises(NoAsyncCallError):
        batch.step_wait()
    batch.step_async(actions)
    with pytest.raises(AlreadyPendingCallError):
        batch.step_async(actions)
    with pytest.raises(AlreadyPendingCallError):
        batch.reset()
    assert_same(sync.step(actions), batch.step_wait())
    assert_same(sync.step(actions), batch.step(actions))
    sync.close()
    batch.close()


@pytest.mark.parametrize("context", ["fork", "forkserver", "spawn"])
def test_start_methods_match_sync_vector_env(context):
    kwargs = {"max_episode_steps": EPISODE}
    vector = make_batch("tinyrace/CarRacing-v0", 3, workers=2, context=context, **kwargs)
    expected = run(gym.vector.SyncVectorEnv([FACTORIES["procedural"]] * 3), steps=50)
    for step, (a, b) in enumerate(zip(expected, run(vector, steps=50), strict=True)):
        assert_same(a, b, f"step {step}")


# -- failures ---------------------------------------------------------------------------------
CREATED: set[str] = set()  # the /dev/shm names this test process made


@pytest.fixture(autouse=True)
def _record_created(monkeypatch: pytest.MonkeyPatch) -> None:
    """Record each shared-memory block and named semaphore this process creates: under
    pytest-xdist other tests' vector envs make and free theirs at the same time, so a diff of
    all of /dev/shm would see them."""
    real_init = shared_memory.SharedMemory.__init__

    def init(self: shared_memory.SharedMemory, *args: Any, **kwargs: Any) -> None:
        real_init(self, *args, **kwargs)
        if kwargs.get("create") or (len(args) > 1 and args[1]):
            CREATED.add(self.name)

    real_make_name = synchronize.SemLock._make_name  # type: ignore[attr-defined]

    def make_name() -> str:
        name: str = real_make_name()
        CREATED.add("sem." + name.lstrip("/"))
        return name

    monkeypatch.setattr(shared_memory.SharedMemory, "__init__", init)
    monkeypatch.setattr(synchronize.SemLock, "_make_name", staticmethod(make_name))


def segments() -> set[str]:
    """The entries of /dev/shm that this process created and that are still there."""
    present = {path.name for path in SHM.iterdir()} if SHM.is_dir() else set()
    return present & CREATED


@pytest.mark.parametrize(
    ("num_envs", "workers", "slice_name"), [(4, 2, "envs 2-3"), (2, 2, "envs 1")]
)
def test_a_raising_env_is_named_by_its_index(num_envs, workers, slice_name):
    """In a slice of several envs and in a slice of one (its own step)."""
    vector = BatchVectorEnv([Doomed] * num_envs, workers=workers)
    vector.reset(seed=0)
    actions = np.zeros((num_envs, 1), np.float32)
    actions[-1] = 0.9
    with bounded(), pytest.raises(KeyError, match=r"refused 0\.9") as raised:
        vector.step(actions)
    notes = "\n".join(raised.value.__notes__)
    assert f"raised by env {num_envs - 1}" in notes and f"worker 1 ({slice_name})" in notes
    still = vector.step(np.zeros((num_envs, 1), np.float32))[1]  # still usable
    assert still.tolist() == [1.0] * num_envs
    vector.close()


@pytest.mark.parametrize("context", ["fork", "spawn"])
def test_a_killed_worker_is_named_never_a_hang(context):
    before = segments()
    vector = BatchVectorEnv([Doomed] * 4, workers=2, context=context)
    assert len({name for name in segments() - before if name.startswith("psm_")}) == 1
    vector.reset(seed=0)
    with bounded(), pytest.raises(RuntimeError) as raised:
        vector.step(np.array([[0.0], [0.0], [-0.9], [0.0]], np.float32))
    message = str(raised.value)
    assert "worker 1 (envs 2-3) died" in message and "killed by SIGKILL" in message
    assert vector.closed and not {n for n in segments() - before if n.startswith("psm_")}
    del raised  # its traceback holds the semaphores the parent waited on
    gc.collect()
    assert segments() <= before  # the semaphores are gone too
    with pytest.raises(gym.error.ClosedEnvironmentError):
        vector.step(np.zeros((4, 1), np.float32))


def test_a_worker_that_cannot_start_is_the_one_error_and_frees_everything(monkeypatch):
    """``Process.start`` failing for the second worker (a spawned script without a main
    guard, say): its error alone, the first worker ended, the memory and semaphores freed."""
    context = multiprocessing.get_context("fork")
    real_start = context.Process.start
    started: list[Any] = []

    def start(process: Any) -> None:
        if started:
            raise RuntimeError("no second worker")
        real_start(process)
        started.append(process)

    monkeypatch.setattr(context.Process, "start", start)
    ignored: list[Any] = []
    monkeypatch.setattr(sys, "unraisablehook", ignored.append)
    before = segments()
    with pytest.raises(RuntimeError, match="no second worker") as caught:
        BatchVectorEnv([Doomed] * 2, workers=2, context="fork")
    assert caught.value.__context__ is None  # not raised while another was handled
    gc.collect()
    assert ignored == []
    assert not started[0].is_alive()
    assert segments() <= before


NO_GUARD = """
import multiprocessing
multiprocessing.set_start_method({method!r}, force=True)
from tinyrace.vector import make_batch
envs = make_batch("tinyrace/CarRacing-v0", num_envs=4, workers=2)
"""


@pytest.mark.parametrize("method", ["spawn", "forkserver"])
def test_a_script_without_a_main_guard_gets_an_error_that_says_so_not_a_hang(tmp_path, method):
    """A spawned worker runs the script again and dies starting its own vector env. The
    parent used to hang sending the worker its start (the layout pickled with the
    observation space, 110 KB: more than the pipe holds, and the worker gone)."""
    if method not in multiprocessing.get_all_start_methods():
        pytest.skip(f"no {method} start method on this platform")
    script = tmp_path / "no_guard.py"
    script.write_text(NO_GUARD.format(method=method))
    here = {"PYTHONPATH": str(Path(tinyrace.__file__).parents[1])}  # this tinyrace, not another
    done = subprocess.run(
        [sys.executable, str(script)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
        env={**os.environ, **here},
    )
    assert done.returncode == 1
    assert "WorkerDied: BatchVectorEnv worker 0 (envs 0-1) died without an answer" in done.stderr
    assert f"A worker started by {method!r} imports the main script again" in done.stderr


def test_closing_frees_the_shared_memory():
    before = segments()
    vector = make_batch("tinyrace/CarRacing-v0", 2, workers=2)
    (name,) = {name for name in segments() - before if name.startswith("psm_")}
    vector.reset(seed=0)
    vector.step(np.zeros((2, 3), np.float32))
    vector.close()
    assert name not in segments()
    with pytest.raises(FileNotFoundError):  # a failed construction frees it too
        BatchVectorEnv([Doomed, functools.partial(open, "/nonexistent/track")], workers=2)
    assert segments() <= before
    in_process = make_batch("tinyrace/CarRacing-v0", 2, workers=0)
    assert segments() <= before  # workers=0 shares nothing
    in_process.close()


# -- EnvPool-style asynchronous stepping ------------------------------------------------------
def _action(env: int, step: int) -> np.ndarray:
    """Env ``env``'s action at its ``step``-th step: the same in every stepping order."""
    rng = np.random.default_rng(1000 * env + step)
    return np.array([rng.uniform(-1, 1), rng.uniform(0, 1), rng.uniform(0, 0.2)], np.float32)


def test_async_batches_give_each_env_its_sync_trajectory():
    num_envs, steps = 4, 60
    sync = gym.vector.SyncVectorEnv([FACTORIES["procedural"]] * num_envs)
    sync.reset(seed=3)
    expected = [[] for _ in range(num_envs)]
    for step in range(steps):
        actions = np.stack([_action(i, step) for i in range(num_envs)])
        observations, rewards, terminated, truncated, _ = sync.step(actions)
        for i in range(num_envs):
            expected[i].append((observations[i], rewards[i], terminated[i], truncated[i]))
    sync.close()
    pool = AsyncBatch(BatchVectorEnv([FACTORIES["procedural"]] * num_envs, workers=2), 2)
    pool.reset(seed=3)
    got = [[] for _ in range(num_envs)]
    pool.send(np.stack([_action(i, 0) for i in range(num_envs)]), np.arange(num_envs))
    with bounded():
        while min(len(g) for g in got) < steps:
            observations, rewards, terminated, truncated, infos = pool.recv()
            ids = infos["env_id"]
            assert len(ids) == 2 and sorted(ids.tolist()) in ([0, 1], [2, 3])
            assert infos["speed"].shape == (2,) and infos["_speed"].all()
            for row, i in enumerate(ids.tolist()):
                got[i].append((observations[row], rewards[row], terminated[row], truncated[row]))
            if all(len(got[i]) < steps for i in ids.tolist()):
                pool.send(np.stack([_action(i, len(got[i])) for i in ids.tolist()]), ids)
        while pool.in_flight:
            pool.recv()
    for i in range(num_envs):
        for step, (a, b) in enumerate(zip(expected[i], got[i][:steps], strict=True)):
            assert np.array_equal(a[0], b[0]) and a[1:] == b[1:], (i, step)
    with pytest.raises(ValueError, match="every env of worker 0"):
        pool.send(np.zeros((1, 3), np.float32), [0])
    pool.close()


def test_a_worker_attaches_the_block_without_registering_it(monkeypatch):
    """Only the parent, which makes and unlinks the block, registers it with the resource
    tracker; a worker's registration could outlive the parent's unlink ("leaked
    shared_memory ... No such file" at exit)."""
    from multiprocessing import resource_tracker

    registered = []
    monkeypatch.setattr(resource_tracker, "register", lambda name, rtype: registered.append(name))
    monkeypatch.setattr(resource_tracker, "unregister", lambda name, rtype: None)
    block = shared.create_block(64)
    try:
        assert registered == [block._name]  # the parent's, on creation
        attached = shared.attach_block(block.name)
        attached.buf[0] = 7
        assert block.buf[0] == 7 and registered == [block._name]
        attached.close()
        shared.attach_block(block.name).close()
        assert registered == [block._name]
        assert resource_tracker.register is not shared._not_registered  # put back
    finally:
        shared.free_block(block)
