"""The parent's end of a BatchVectorEnv's workers: start them, wake them, wait, stop them.

Each worker has a pipe (commands other than a step, and what does not fit in the shared
memory), two semaphores (``go``: the parent wakes it; ``done``: it has answered) and a
command word in the shared memory. A step is ``STEP`` in every command word and a
``go`` each; every other command goes over the pipe, announced by ``PIPE``.

Waiting for the workers' step, the parent polls its ``done`` semaphores for a short time
when steps are short (an answer within the spin costs no wake-up), else it sleeps on them
at once, leaving the cores to the workers, and looks every
``LIVENESS`` seconds whether they live. A worker that dies closes the vector env and is
named, never a hang.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from multiprocessing.connection import Connection
from multiprocessing.reduction import ForkingPickler
from typing import Any

import cv2
import gymnasium as gym
from gymnasium.vector.utils import CloudpickleWrapper

from tinyrace.vector import shared
from tinyrace.vector.envslice import EnvSlice
from tinyrace.vector.failures import await_close, died, rebuild_error
from tinyrace.vector.inparent import ParentPipe, ParentWorker
from tinyrace.vector.worker import acquire, work

CLOSE_TIMEOUT = 10.0  # [s] a worker gets to finish its command and close its envs
# [s] the parent polls for the workers' answers this long before it sleeps (a step of
# a few envs takes less: the answer comes without a wake-up); after a step that took
# longer it sleeps at once, leaving the cores to the workers. Measured against 0.5 and
# 0.1 ms (benchmarks/README.md, issue 37): the same for 1 env in 1 worker, the best for
# the stand-ins' ceiling
PARENT_SPIN = 0.002
LIVENESS = 0.05  # [s] a sleeping parent looks this often whether the workers live


class Workers:
    """The worker processes of one vector env, each stepping one of ``slices``.

    ``on_failure`` is called (the vector env closes) before a dead worker is reported.
    With ``parent_steps`` the last slice is the parent's own (``tinyrace.vector.inparent``):
    worker number ``len(slices) - 1``, no process, its "pipe" a queue.
    """

    def __init__(
        self, slices: list[slice], on_failure: Callable[[], None], parent_steps: bool = False
    ) -> None:
        self.slices = slices
        self.on_failure = on_failure
        self.spawned = len(slices) - parent_steps  # worker processes
        self.parent: ParentWorker | None = None  # the parent's slice, once started
        self.pipes: list[Connection] = []  # per worker process
        self.processes: list[Any] = []
        self.semaphores: list[tuple[Any, Any]] = []  # (go, done) per worker process
        self.command: Any = None  # the shared command words, once started
        # where each worker's answers beyond the shared memory come from, in order: the
        # processes' pipes, then the parent's slice's queue (set once started)
        self.answers: list[Connection | ParentPipe] = []
        self.spin = PARENT_SPIN  # [s] how long the parent polls for the next answers

    def start(
        self,
        ctx: Any,
        env_fns: list[Callable[[], gym.Env[Any, Any]]],
        block: tuple[str, shared.Layout],
        views: shared.Views,
        physics: tuple[bool, int],
        cores: list[int] | None = None,
    ) -> None:
        """Start one process per slice, attached to the shared memory ``block`` (the
        parent's slice made here, while the processes make theirs); worker ``i`` pinned
        to core ``cores[i % len(cores)]`` if ``cores`` are given."""
        self.command = views.command
        threads = cv2.getNumThreads()
        cv2.setNumThreads(1)  # see _start
        try:
            self._start(ctx, env_fns, block, physics, cores)
        finally:
            cv2.setNumThreads(threads)
        self.answers = list(self.pipes)
        if self.spawned < len(self.slices):
            envs = self.slices[-1]
            own = EnvSlice(env_fns[envs], envs.start, views, *physics)
            self.parent = ParentWorker(self.spawned, own, views)
            self.answers.append(self.parent.queue)

    def _start(
        self,
        ctx: Any,
        env_fns: list[Callable[[], gym.Env[Any, Any]]],
        block: tuple[str, shared.Layout],
        physics: tuple[bool, int],
        cores: list[int] | None,
    ) -> None:
        """Start the worker processes, with OpenCV on one thread in this process: OpenCV's
        thread pool does not survive a fork, and a forked worker that used it (its state
        copied from a pool whose threads were busy at the fork) could wait forever in its
        first parallel call (a `cv2.resize` seen hanging so in CI). A forked worker keeps
        that one thread, as a worker steps on one core anyway."""
        for number, envs in enumerate(self.slices[: self.spawned]):
            parent, child = ctx.Pipe()
            semaphores = (ctx.Semaphore(0), ctx.Semaphore(0))  # go, done
            fns = [CloudpickleWrapper(fn) for fn in env_fns[envs]]
            process = ctx.Process(
                target=work,
                args=(child, parent, number, fns, envs.start, block, semaphores, *physics),
                kwargs={"core": None if cores is None else cores[number % len(cores)]},
                name=f"BatchVectorEnv-worker-{number}",
                daemon=True,
            )
            try:
                process.start()
            except BaseException:  # e.g. a spawned script without a main guard
                parent.close()
                raise
            finally:
                child.close()
            self.pipes.append(parent)
            self.semaphores.append(semaphores)
            self.processes.append(process)

    def step(self, numbers: list[int] | range | None = None) -> None:
        """Wake the workers ``numbers`` (default: all) to step their envs; the parent's
        slice, if among them, is stepped here meanwhile (done when this returns)."""
        command = self.command
        ours = False
        for number in range(len(self.slices)) if numbers is None else numbers:
            if number == self.spawned:
                ours = True
                continue
            command[number] = shared.STEP
            self.semaphores[number][0].release()
        if ours:
            assert self.parent is not None
            try:
                self.parent.step()  # its exception is its answer, as a worker's
            except BaseException:  # e.g. Ctrl-C: the workers would be out of step
                self.on_failure()
                raise

    def wait_all(self) -> None:
        """Wait for every worker process's step; a step that outlasted the spin will
        likely again: the next wait sleeps at once."""
        start = time.perf_counter()
        for number in range(self.spawned):
            self.await_done(number)
        self.spin = PARENT_SPIN if time.perf_counter() - start < PARENT_SPIN else 0.0

    def await_done(self, number: int) -> None:
        """Wait for worker ``number``'s step; if it dies meanwhile, close and say so."""
        done = self.semaphores[number][1]
        if acquire(done, self.spin):
            return
        process = self.processes[number]
        try:
            while not done.acquire(timeout=LIVENESS):
                if not process.is_alive():
                    self.on_failure()
                    raise died(number, self.slices[number], process.exitcode)
        except BaseException:  # e.g. Ctrl-C: the workers would be out of step
            self.on_failure()
            raise

    def check_alive(self, numbers: list[int]) -> None:
        """Close and raise if one of the workers ``numbers`` has died."""
        for number in numbers:
            process = self.processes[number]
            if not process.is_alive():
                self.on_failure()
                raise died(number, self.slices[number], process.exitcode)

    # -- commands over the pipes ----------------------------------------------------------
    def send(self, command: str, args: list[tuple[Any, ...]]) -> None:
        # all pickled first: an argument that cannot be pickled leaves the pipes in step
        messages = [ForkingPickler.dumps((command, a)) for a in args[: self.spawned]]
        for number, message in enumerate(messages):
            with contextlib.suppress(OSError):  # a dead worker: reported by receive_all
                self.signal(number, message)
        if self.parent is not None:
            try:
                self.parent.run(command, args[-1])
            except BaseException:  # e.g. Ctrl-C: the workers would be out of step
                self.on_failure()
                raise

    def signal(self, number: int, message: bytes | memoryview) -> None:
        """Put ``message`` in worker ``number``'s pipe and wake it to read it."""
        self.pipes[number].send_bytes(message)
        self.command[number] = shared.PIPE
        self.semaphores[number][0].release()

    def receive_all(self) -> list[Any]:
        """Every worker's answer, in order; the first worker's exception is raised here."""
        replies = []
        for number, pipe in enumerate(self.answers):
            try:
                replies.append(pipe.recv())  # the parent's slice: a queued answer
            except (EOFError, OSError):  # no answer will ever come
                process = self.processes[number]
                process.join(CLOSE_TIMEOUT)
                self.on_failure()
                raise died(number, self.slices[number], process.exitcode) from None
            except BaseException:  # e.g. Ctrl-C: the pipes would be out of step
                self.on_failure()
                raise
        for number, (ok, result) in enumerate(replies):
            if not ok:
                raise rebuild_error(result, number, self.slices[number])
        return [result for _, result in replies]

    def close(self) -> None:
        """Ask every worker to close its envs; terminate any that hang."""
        message = ForkingPickler.dumps(("close", ()))
        for number in range(len(self.processes)):
            with contextlib.suppress(OSError, ValueError):  # a worker that is gone already
                self.signal(number, message)
        parent, self.parent = self.parent, None
        try:
            if parent is not None:
                parent.run("close", ())
        finally:
            self._join()

    def _join(self) -> None:
        """Wait for the processes told to close; terminate any that hang."""
        for pipe, process in zip(self.pipes, self.processes, strict=True):
            await_close(pipe, CLOSE_TIMEOUT)
            pipe.close()
            process.join(CLOSE_TIMEOUT)
            if process.is_alive():
                process.terminate()
                process.join()
        self.pipes, self.processes, self.semaphores, self.answers = [], [], [], []
        self.command = None
