"""Stopping a run cleanly on SIGINT or SIGTERM: the first signal asks the episode loop to stop
after the current step (files and videos are then finished); a second one stops at once."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType
from typing import Any

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(BaseException):
    """The run was stopped by a signal (a BaseException, like KeyboardInterrupt)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class StopSignals:
    """A context that turns SIGINT and SIGTERM into a stop request, checked by ``check()``.

    Outside the main thread signals cannot be caught: the context then does nothing.
    """

    def __init__(self) -> None:
        self.signum: int | None = None
        self.holding = False  # inside hold(): the files are written, signals only noted
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            for signum in SIGNALS:
                self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc_info: object) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        self._previous.clear()

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.signum is not None and not self.holding:  # asked twice: do not wait for the step
            raise Interrupted(signum)
        self.signum = self.signum or signum

    @contextlib.contextmanager
    def hold(self) -> Iterator[None]:
        """A block that signals do not break (the run's files being written): they are noted."""
        self.holding = True
        try:
            yield
        finally:
            self.holding = False

    def check(self) -> None:
        """Raise Interrupted if a stop was asked for."""
        if self.signum is not None:
            raise Interrupted(self.signum)
