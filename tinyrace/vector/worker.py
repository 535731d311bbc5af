"""The worker process of BatchVectorEnv: it steps its slice of the envs per command.

A step needs no message: the parent writes the actions into the shared memory, sets
the worker's command word to ``STEP`` and releases its ``go`` semaphore; the worker
writes observations, rewards, flags and infos into the shared memory, its status word,
and releases ``done``. Only what does not fit (an info of a new shape, an exception)
goes over the pipe, before ``done``. Every other command (reset, call, set_attr, close)
comes over the pipe, announced by the command word ``PIPE``.

Waiting, each side first polls its semaphore for a short time (yielding its core to
any other process meanwhile), then sleeps on it: waking a sleeping process on another
core costs 0.05-0.5 ms on a virtual machine, as much as a few env steps.
"""

from __future__ import annotations

import contextlib
import gc
import multiprocessing
import os
import pickle
import signal
import struct
import time
import traceback
from collections.abc import Callable
from multiprocessing.connection import Connection
from multiprocessing.synchronize import Semaphore
from typing import Any

import gymnasium as gym

from tinyrace.vector import records, shared
from tinyrace.vector.batched import NUMPY_FROM
from tinyrace.vector.envslice import EnvSlice

# [s] a worker polls for its next command this long before it sleeps
WORKER_SPIN = 0.0005
ONE_BY_ONE = 4  # a worker with at most this many envs writes their results one by one
PARENT_CHECK = 1.0  # [s] a sleeping worker looks this often whether its parent is alive
CLOSED = "closed"  # a worker's last answer
yield_core = getattr(os, "sched_yield", lambda: time.sleep(0))  # no sched_yield on Windows


def acquire(semaphore: Semaphore, spin: float) -> bool:
    """Take ``semaphore`` if it is released within ``spin`` seconds (without sleeping)."""
    if semaphore.acquire(False):
        return True
    deadline = time.perf_counter() + spin
    while time.perf_counter() < deadline:
        yield_core()
        if semaphore.acquire(False):
            return True
    return False


class Worker:
    """One worker's envs and its end of the shared memory, the semaphores and the pipe."""

    def __init__(
        self,
        pipe: Connection,
        number: int,
        envs: EnvSlice,
        views: shared.Views,
        semaphores: tuple[Semaphore, Semaphore],
    ) -> None:
        self.pipe, self.number, self.envs, self.views = pipe, number, envs, views
        self.go, self.done = semaphores
        self.rows = slice(envs.first, envs.first + len(envs.envs))
        # this slice's rows of the shared arrays, made once (a slice per step costs more)
        self.actions = None if views.actions is None else views.actions[self.rows]
        self.rewards = views.rewards[self.rows]
        self.terminated = views.terminated[self.rows]
        self.truncated = views.truncated[self.rows]
        self.infos, self.kinds = views.infos[self.rows], views.kinds[self.rows]
        self.uniform = views.uniform
        self.one_by_one = len(envs.envs) <= ONE_BY_ONE
        # the slice's records as bytes, where ``struct`` packs them
        self.info_bytes = memoryview(self.infos).cast("B")  # type: ignore[arg-type]
        # per signature announced to the parent: its number and its record's packer
        self.known: dict[records.Signature, tuple[int, Callable[..., None]]] = {}
        self.settled = False  # the heap frozen after the first reset (``settle``)

    def serve(self) -> None:
        """Answer commands until "close" or the parent's end."""
        parent = multiprocessing.parent_process()
        while True:
            if not acquire(self.go, WORKER_SPIN):
                while not self.go.acquire(timeout=PARENT_CHECK):
                    if parent is not None and not parent.is_alive():
                        return
            views = self.views
            views.observations = views.buffers[views.buffer[0]]  # the parent's choice
            if views.command[self.number] == shared.STEP:
                self.step()
                continue
            try:
                command, args = self.pipe.recv()
            except EOFError:  # the parent is gone
                return
            answer = self.run(command, args)
            if command == "close":
                return
            # the first reset of one of its envs (None: an env left out by a reset mask)
            reset_one = command == "reset" and any(r is not None for r in answer or ())
            if reset_one and not self.settled:
                settle()  # this process's heap, never the parent's: its slice runs no serve
                self.settled = True

    def run(self, command: str, args: tuple[Any, ...]) -> Any:
        """Carry out a command other than a step and send its answer; return it (None when
        the command raised)."""
        if command == "close":
            self.envs.close()
            self.pipe.send((True, CLOSED))
            return None
        try:
            answer = getattr(self.envs, command)(*args)
        except Exception as error:
            self.fail(error)
            return None
        self.pipe.send((True, answer))
        return answer

    def step(self) -> None:
        status = self.views.status
        try:
            actions = self.actions.copy()  # type: ignore[union-attr]  # the env may keep it
            rewards, terminated, truncated, infos = self.envs.step(actions)
            if self.one_by_one:  # a few scalar writes cost less than converting lists
                for j, reward in enumerate(rewards):
                    self.rewards[j] = reward
                    self.terminated[j] = terminated[j]
                    self.truncated[j] = truncated[j]
            else:
                self.rewards[:] = rewards
                self.terminated[:] = terminated
                self.truncated[:] = truncated
            status[self.number] = self._write_infos(infos)
        except Exception as error:
            status[self.number] = shared.FAILED
            self.fail(error)
        self.done.release()

    def fail(self, error: Exception) -> None:
        """Send the parent ``error``, described (a pickled exception may not unpickle)."""
        self.pipe.send((False, describe(error)))

    def _write_infos(self, infos: list[dict[str, Any]]) -> int:
        """Pack each env's info into its record, its signature's number into ``kinds``
        (numbering the signatures not seen before and sending them first); infos that do
        not fit go over the pipe. The status that says which."""
        known, fresh, numbers = self.known, list[records.Signature](), []
        empty = known.get(())
        if empty is not None and infos.count({}) == len(infos):  # as many envs' are: no records
            self.kinds[:] = empty[0]
            self.uniform[self.number] = empty[0]
            return shared.KNOWN
        buffer, offset = self.info_bytes, 0
        for info in infos:
            flat = records.flatten(info)
            if flat is None:
                return self._by_pipe(infos, fresh)
            signature, values = flat
            place = known.get(signature)
            if place is None:
                layout = records.record_struct(signature)
                if layout is None:
                    return self._by_pipe(infos, fresh)
                place = known[signature] = (len(known), layout.pack_into)
                fresh.append(signature)
            number, pack_into = place
            try:
                pack_into(buffer, offset, *values)
            except (struct.error, OverflowError, TypeError, ValueError):  # e.g. a 65-bit int
                return self._by_pipe(infos, fresh)
            numbers.append(number)
            offset += records.INFO_BYTES
        self.kinds[:] = numbers
        first = numbers[0]
        self.uniform[self.number] = first if numbers.count(first) == len(numbers) else -1
        if not fresh:
            return shared.KNOWN
        self.pipe.send(fresh)
        return shared.NEW_SIGNATURES

    def _by_pipe(self, infos: list[dict[str, Any]], fresh: list[records.Signature]) -> int:
        """Send ``infos`` as they are, forgetting the signatures numbered for them."""
        for signature in fresh:
            del self.known[signature]
        self.pipe.send(infos)
        return shared.INFOS_BY_PIPE


def work(
    pipe: Connection,
    parent: Connection,
    number: int,
    env_fns: list[Callable[[], gym.Env[Any, Any]]],
    first: int,
    block: tuple[str, shared.Layout],
    semaphores: tuple[Semaphore, Semaphore],
    batch_physics: bool = True,
    numpy_from: int = NUMPY_FROM,
    core: int | None = None,
) -> None:
    """A worker process: its inherited objects frozen (``gc.freeze``), pinned to ``core``
    if given, attach the shared memory, build the envs (their memory touched first on that
    core), serve the commands (freezing again after the first reset: ``settle``).

    OpenCV's thread count is not set here: ``cv2.setNumThreads`` in a forked worker whose
    parent had started OpenCV's threads hangs (it waits on the parent's thread pool, which
    the child does not have). The parent forks it with that count at 1 instead
    (``link.Workers._start``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    parent.close()
    # the objects this process inherited from its parent (all of them, when forked): its
    # collections skip them, so they neither traverse the parent's heap (a learner's
    # model, the garbage of envs closed before) nor copy its pages by touching them
    gc.freeze()
    if core is not None:
        os.sched_setaffinity(0, {core})  # the parent checked it is one of its cores
    name, layout = block
    memory = shared.attach_block(name)
    views = layout.views(memory.buf)
    try:
        envs = EnvSlice(env_fns, first, views, batch_physics, numpy_from)
    except Exception as error:
        pipe.send((False, describe(error)))
        return
    pipe.send((True, envs.spaces()))
    try:
        Worker(pipe, number, envs, views, semaphores).serve()
    finally:
        del views
        with contextlib.suppress(BufferError):  # views still held: freed with the process
            memory.close()


def settle() -> None:
    """Freeze what the first reset left alive (``gc.freeze``), once per worker.

    An env imports much on first use: tinyrace's CarRacing loads its compiled kernels at
    its first reset, and with them numba, llvmlite and parts of scipy, some 90,000 objects
    that live as long as the process. Left to the collector, each full collection would
    traverse them all, while the other workers of the step wait for this one. Frozen, they
    are skipped. What is frozen is never collected as a cycle: the first episode's objects
    that form cycles stay in memory once the envs have moved on (a bounded, one-time cost;
    later episodes' garbage is collected as before). Its cost and gain are measured in
    benchmarks/README.md."""
    gc.collect()
    gc.freeze()


def describe(error: Exception) -> tuple[str, str, str, bytes | None]:
    """(type name, message, traceback text, the pickled exception or None)."""
    try:
        pickled: bytes | None = pickle.dumps(error)
    except Exception:
        pickled = None
    return type(error).__name__, str(error), traceback.format_exc(), pickled
