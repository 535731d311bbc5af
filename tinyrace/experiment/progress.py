"""A dependency-free progress bar on stderr (one line per episode when not a terminal)."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    """Shows episode i of n and the steps done, at most ten redraws a second."""

    def __init__(self, episodes: int, stream: TextIO | None = None, enabled: bool = True):
        self.episodes = episodes
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.live = enabled and self.stream.isatty()
        self._last = 0.0
        self._started = time.perf_counter()

    def update(self, episode: int, steps: int, limit: int) -> None:
        if not self.live or time.perf_counter() - self._last < 0.1:
            return
        self._last = time.perf_counter()
        done = (episode + min(steps / max(limit, 1), 1.0)) / self.episodes
        bar = "#" * int(done * 30)
        rate = steps / max(time.perf_counter() - self._episode_started, 1e-9)
        where = f"episode {episode + 1}/{self.episodes}  step {steps}"
        self.stream.write(f"\r[{bar:<30}] {where}  {rate:,.0f} steps/s ")
        self.stream.flush()

    def start_episode(self) -> None:
        self._episode_started = time.perf_counter()

    def end_episode(self, episode: int, summary: str) -> None:
        if not self.enabled:
            return
        prefix = "\r" if self.live else ""
        self.stream.write(f"{prefix}episode {episode + 1}/{self.episodes}: {summary}{' ' * 20}\n")
        self.stream.flush()
