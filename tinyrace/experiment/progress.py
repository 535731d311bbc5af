"""Where a run is, on stderr: a tqdm bar per episode on a terminal (steps, return, lap
progress, steps/s), and one line per finished episode everywhere (also in logs and pipes)."""

from __future__ import annotations

import sys
import time
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    from tqdm import tqdm

    from tinyrace.experiment.record import EpisodeRecorder
    from tinyrace.experiment.results import EpisodeResult


class Progress:
    """Shows where a run is; ``enabled=False`` shows nothing (``--quiet``).

    ``interval`` [s]: the bar is redrawn at most this often.
    """

    def __init__(
        self,
        episodes: int,
        limit: int = 0,
        stream: TextIO | None = None,
        enabled: bool = True,
        interval: float = 0.1,
        video: bool = True,
    ):
        self.episodes = episodes
        self.video = video  # whether the wall time includes writing a video
        self.limit = limit  # steps per episode at most (0: unknown)
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.live = enabled and self.stream.isatty()  # a bar only where it can be redrawn
        self.interval = interval
        self._bar: tqdm[Any] | None = None
        self._episode = 0
        self._episode_started = time.perf_counter()

    def start_episode(self, episode: int) -> None:
        self._episode = episode
        self._episode_started = time.perf_counter()
        if self.live:
            from tqdm import tqdm

            self.close()
            self._bar = tqdm(
                total=self.limit or None,
                desc=self.name(episode),
                unit="step",
                file=self.stream,
                leave=False,
                mininterval=self.interval,
                dynamic_ncols=True,
            )

    def name(self, episode: int) -> str:
        """``episode 3 (4/5)``: the number of the tables and files (from 0), then the count."""
        return f"episode {episode} ({episode + 1}/{self.episodes})"

    def elapsed(self) -> float:
        """[s] of wall time in the current episode so far (videos included)."""
        return time.perf_counter() - self._episode_started

    def rate(self, steps: int, left_out: float = 0.0) -> float:
        """[steps/s] in the current episode so far, ``left_out`` seconds (video) not counted."""
        return steps / max(self.elapsed() - left_out, 1e-9)

    def update(self, recorder: EpisodeRecorder) -> None:
        """After a step: the bar's step count, return and lap progress."""
        bar = self._bar
        if bar is None:
            return
        bar.set_postfix_str(
            f"return {recorder.episode_return:.1f}, lap {_lap(recorder.info)}", refresh=False
        )
        bar.update(recorder.steps - bar.n)

    def end_episode(self, episode: int, result: EpisodeResult) -> None:
        """The episode's line: return, steps, lap time and how it ended."""
        self.close()
        if not self.enabled:
            return
        lap = f", lap {result.lap_time:.2f} s" if result.lap_time is not None else ""
        summary = f"return {result.episode_return:.1f}, {result.steps} steps{lap}, {result.end}"
        summary += f"; simulated {result.steps_per_second:.0f} steps/s"
        if result.wall_seconds is not None:
            video = " (video included)" if self.video else ""
            summary += f", {result.wall_seconds:.1f} s wall{video}"
        self.stream.write(f"{self.name(episode)}: {summary}\n")
        self.stream.flush()

    def close(self) -> None:
        """Clear the bar (at an episode's end, and when a run stops early)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def _lap(info: dict[str, Any]) -> str:
    """Lap progress: the share of tiles visited (tracks with progress tiles); '-' where the
    env counts no tiles (image tracks)."""
    total = info.get("tiles_total")
    if not total:
        return "-"
    return f"{100 * info.get('tiles_visited', 0) / total:.0f}%"
