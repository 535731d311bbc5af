"""The slice of a BatchVectorEnv's envs that the parent process steps itself.

With ``parent_steps=True`` the parent steps the last slice while the worker processes step
theirs, instead of waiting for them: on a machine with a core for each worker and one for
the parent, no core is left idle and no worker shares its core with a polling parent
(benchmarks/README.md, issue 37). The slice answers as a worker does, through the same
shared arrays (rewards, flags, info records, status words), so the parent reads every
slice's answers alike; what a worker would send over its pipe (new info signatures, infos
that do not fit, its answers to other commands) waits in a queue instead, and an
exception stays the exception itself, not a pickled copy.
"""

from __future__ import annotations

import collections
from typing import Any

import cv2

from tinyrace.vector.envslice import EnvSlice
from tinyrace.vector.shared import Views
from tinyrace.vector.worker import Worker


class ParentPipe:
    """What the parent's own slice would send over a pipe, kept until it is read."""

    def __init__(self) -> None:
        self.answers: collections.deque[Any] = collections.deque()

    def send(self, answer: Any) -> None:
        self.answers.append(answer)

    def recv(self) -> Any:
        return self.answers.popleft()

    def close(self) -> None:
        self.answers.clear()


class _Released:
    """A semaphore nobody waits on: the parent's slice has answered when its step returns."""

    def release(self) -> None:
        pass


class ParentWorker(Worker):
    """The parent's slice, answering steps and commands (``Worker.run``) as a worker
    process would, into its queue."""

    def __init__(self, number: int, envs: EnvSlice, views: Views) -> None:
        pipe = ParentPipe()
        super().__init__(pipe, number, envs, views, (_Released(), _Released()))  # type: ignore[arg-type]
        self.queue = pipe
        pipe.send((True, envs.spaces()))  # as a worker's first answer

    def step(self) -> None:
        """The slice's step with OpenCV on one thread, as in a forked worker: its thread
        pool would spread each warp over the cores the workers are stepping on."""
        threads = cv2.getNumThreads()
        cv2.setNumThreads(1)
        try:
            super().step()
        finally:
            cv2.setNumThreads(threads)

    def fail(self, error: Exception) -> None:
        self.queue.send((False, error))  # the exception itself, with its traceback
