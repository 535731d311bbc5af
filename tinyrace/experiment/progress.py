"""A dependency-free progress bar on stderr: episode, step, return and lap progress, redrawn
at most ten times a second on a terminal; one line per finished episode otherwise."""

from __future__ import annotations

import sys
import time
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    from tinyrace.experiment.record import EpisodeRecorder
    from tinyrace.experiment.results import EpisodeResult


class Progress:
    """Shows where a run is; ``enabled=False`` shows nothing (``--quiet``)."""

    def __init__(
        self, episodes: int, limit: int = 0, stream: TextIO | None = None, enabled: bool = True
    ):
        self.episodes = episodes
        self.limit = limit  # steps per episode at most (0: unknown)
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.live = enabled and self.stream.isatty()
        self._last = 0.0
        self._episode = 0
        self._episode_started = time.perf_counter()

    def start_episode(self, episode: int) -> None:
        self._episode = episode
        self._episode_started = time.perf_counter()

    def rate(self, steps: int) -> float:
        """[steps/s] in the current episode so far."""
        return steps / max(time.perf_counter() - self._episode_started, 1e-9)

    def update(self, recorder: EpisodeRecorder) -> None:
        if not self.live or time.perf_counter() - self._last < 0.1:
            return
        self._last = time.perf_counter()
        self._draw(self.line(recorder))

    def line(self, recorder: EpisodeRecorder) -> str:
        """``[####    ] episode 2/5  step 340/1000  return 512.3  lap 64%  8,000 steps/s``."""
        limit = self.limit or recorder.steps
        done = (self._episode + min(recorder.steps / max(limit, 1), 1.0)) / self.episodes
        bar = "#" * int(done * 20)
        steps = f"{recorder.steps}/{self.limit}" if self.limit else str(recorder.steps)
        parts = [
            f"[{bar:<20}] episode {self._episode + 1}/{self.episodes}",
            f"step {steps}",
            f"return {recorder.episode_return:.1f}",
            f"lap {_lap(recorder.info)}",
            f"{self.rate(recorder.steps):,.0f} steps/s",
        ]
        return "  ".join(parts)

    def _draw(self, text: str) -> None:
        self.stream.write(f"\r{text} ")
        self.stream.flush()

    def end_episode(self, episode: int, result: EpisodeResult) -> None:
        if not self.enabled:
            return
        lap = f", lap {result.lap_time:.2f} s" if result.lap_time is not None else ""
        summary = f"return {result.episode_return:.1f}, {result.steps} steps{lap}, {result.end}"
        prefix = "\r" if self.live else ""
        self.stream.write(f"{prefix}episode {episode + 1}/{self.episodes}: {summary}{' ' * 30}\n")
        self.stream.flush()


def _lap(info: dict[str, Any]) -> str:
    """Lap progress: the share of tiles visited (procedural tracks); '-' where laps are not
    counted (image tracks)."""
    total = info.get("tiles_total")
    if not total:
        return "-"
    return f"{100 * info.get('tiles_visited', 0) / total:.0f}%"
