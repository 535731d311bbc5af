"""A run's episode loop and its folder: shared by one car's runs and races."""

from __future__ import annotations

import dataclasses
import datetime as dt
import shutil
from pathlib import Path
from typing import Any, Generic, TypeVar

from tinyrace.env import TinyRaceEnv
from tinyrace.errors import one_line
from tinyrace.experiment.interrupt import Interrupted, StopSignals
from tinyrace.experiment.load import Experiment
from tinyrace.experiment.progress import Progress
from tinyrace.experiment.tracks import save_track_picture
from tinyrace.experiment.video import VideoWriter, open_video

R = TypeVar("R")  # what a run keeps of each episode
DEFAULT_MAX_STEPS = 1000  # when neither the experiment nor the env sets a limit (CarRacing's)


class RunLoop(Generic[R]):
    """A run's episode loop: each episode's result kept, the files written at the end, after
    a signal (the finished episodes) or an error (none finished: no run folder is left)."""

    def __init__(
        self, experiment: Experiment, out_root: Path | None, progress: Progress, limit: int
    ):
        """Claims a new run folder under ``out_root`` (default: ``output.dir``, relative to
        the cwd), made with its parents where missing."""
        self.experiment, self.config = experiment, experiment.config
        root = Path(out_root or self.config.output.dir)
        self.made_root = not root.exists()  # the parent folder was made for this run
        self.run_dir, self.progress = new_run_dir(root, experiment.name), progress
        self.limit = limit  # [steps] per episode at most
        self.results: list[R] = []
        self.tracks: dict[str, dict[str, Any]] = {}
        progress.limit = progress.limit or self.limit

    def all(self) -> int | None:
        """Every episode; the signal that stopped the run (or came after its last step)."""
        interrupted = None
        with StopSignals() as stop:
            try:
                for episode in range(self.config.episodes):
                    self.results.append(self._episode(episode, stop))
            except Interrupted as exc:
                interrupted = exc.signum
            except BaseException as exc:
                self.progress.close()
                with stop.hold():
                    self._fail(exc)
                raise
            self.progress.close()  # an interrupted episode's bar
            with stop.hold():  # a second Ctrl-C does not cut the files short
                if interrupted is None:  # a signal after the last step: still say so
                    interrupted = stop.signum
                self._write(interrupted)
        return interrupted or stop.signum

    def _episode(self, episode: int, stop: StopSignals) -> R:
        raise NotImplementedError

    def _write(self, interrupted: int | None, error: str | None = None) -> None:
        raise NotImplementedError

    def header(
        self, env: TinyRaceEnv, interrupted: int | None, error: str | None
    ) -> dict[str, Any]:
        """results.json's fields before the episodes."""
        return {
            "experiment": self.experiment.source,
            "started": self.run_dir.name,
            "interrupted": interrupted is not None,
            "signal": None if interrupted is None else Interrupted(interrupted).args[0],
            "error": error,
            "episodes_planned": self.config.episodes,
            "track_kind": env.config.kind,
            "track_unit": env.config.facts.unit,  # u, px or m: the report's lengths
            "dt": env.dt,  # [s] per step
            "tracks": self.tracks,
            "config": dataclasses.asdict(self.config),
        }

    def episode_video(self, episode: int, dt: float) -> VideoWriter | None:
        """The episode's video (``episode_NNN``), when ``output`` films it; ``dt`` [s] per
        step gives the frame rate unless ``output.fps`` does."""
        out = self.config.output
        filmed = out.video and (out.video_episodes is None or episode < out.video_episodes)
        if not filmed:
            return None
        fps = out.fps or 1.0 / dt  # [Hz] default: real time
        return open_video(self.run_dir / f"episode_{episode:03d}", fps)

    def track_picture(self, env: TinyRaceEnv, seed: int) -> str:
        key, entry = save_track_picture(env, seed, self.run_dir, self.tracks)
        self.tracks[key] = entry
        return key

    def _fail(self, exc: BaseException) -> None:
        """No finished episode: leave nothing behind; else keep what finished."""
        if not self.results:
            shutil.rmtree(self.run_dir, ignore_errors=True)
            if self.made_root and not any(self.run_dir.parent.iterdir()):
                self.run_dir.parent.rmdir()  # made for this run only
        else:
            self._write(None, error=one_line(exc))


def new_run_dir(root: Path, name: str) -> Path:
    """``root/<name>-<YYYYmmdd-HHMMSS>``, with ``-2``, ``-3``... when taken (by this or
    another process: the folder is claimed by an atomic mkdir)."""
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    root.mkdir(parents=True, exist_ok=True)
    n = 1
    while True:
        run_dir = root / (f"{name}-{stamp}" if n == 1 else f"{name}-{stamp}-{n}")
        try:
            run_dir.mkdir()
        except FileExistsError:
            n += 1
            continue
        return run_dir
