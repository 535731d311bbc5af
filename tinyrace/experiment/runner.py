"""Running an experiment end to end: episodes, driver, videos, traces, metrics, files, report.

Each episode is driven by ``tinyrace.drivers.run_episode`` (the one episode loop); an
``EpisodeRecorder`` watches it. SIGINT/SIGTERM stop the run after the current step: the
finished episodes are written, the run is marked interrupted, the open video is finished.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tinyrace.drivers import Driver, DriverError, load_driver, run_episode
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError, Problem, one_line
from tinyrace.experiment.interrupt import Interrupted, StopSignals
from tinyrace.experiment.load import Experiment, check_view, importable_from
from tinyrace.experiment.progress import Progress
from tinyrace.experiment.record import EpisodeRecorder
from tinyrace.experiment.results import EpisodeResult, summary, summary_text, table, write_files
from tinyrace.experiment.route import route_watch
from tinyrace.experiment.tracks import save_track_picture
from tinyrace.experiment.video import open_video
from tinyrace.sensors.view import sensor_view

DEFAULT_MAX_STEPS = 1000  # when neither the experiment nor the env sets a limit (CarRacing's)


@dataclass
class RunResult:
    """The run folder, the finished episodes, and the signal that stopped the run (if any)."""

    run_dir: Path
    episodes: list[EpisodeResult]
    interrupted: int | None = None  # signal number

    @property
    def summary(self) -> dict[str, dict[str, float]]:
        return summary(self.episodes)


def run_experiment(
    experiment: Experiment,
    out_root: Path | None = None,
    show_progress: bool = True,
    progress: Progress | None = None,
) -> RunResult:
    """Run every episode; write results.json, episodes.csv, traces, videos and report.html
    into a new run folder under ``out_root`` (default: ``output.dir``, relative to the cwd).

    Raises ConfigError for a bad view or driver (no run folder is left behind when no
    episode finished).
    """
    config = experiment.config
    render_mode = "rgb_array" if config.output.video and config.output.view == "default" else None
    env = TinyRaceEnv(config=experiment.loaded, render_mode=render_mode)
    try:
        check_view(experiment.config, env.config, experiment.source)
        with importable_from(experiment.folder):  # own drivers sit beside the experiment file
            driver = _driver(config.driver, config.driver_args, experiment.source)
        progress = progress or Progress(config.episodes, enabled=show_progress)
        root = Path(out_root or config.output.dir)
        made_root = not root.exists()
        run = _Run(experiment, env, driver, new_run_dir(root, experiment.name), progress)
        run.made_root = made_root
        return run.all()
    finally:
        env.close()


class _Run:
    """One run's state: the finished episodes and the track pictures saved so far."""

    def __init__(
        self,
        experiment: Experiment,
        env: TinyRaceEnv,
        driver: Driver,
        run_dir: Path,
        progress: Progress,
    ):
        self.experiment, self.config = experiment, experiment.config
        self.env, self.driver, self.run_dir, self.progress = env, driver, run_dir, progress
        self.limit = self.config.max_steps or env.config.sim.step_limit or DEFAULT_MAX_STEPS
        self.results: list[EpisodeResult] = []
        self.tracks: dict[str, dict[str, Any]] = {}
        self.made_root = False  # the parent folder was made for this run
        progress.limit = progress.limit or self.limit

    def all(self) -> RunResult:
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
        return RunResult(self.run_dir, self.results, interrupted or stop.signum)

    def _episode(self, episode: int, stop: StopSignals) -> EpisodeResult:
        seed = self.config.seed + episode
        recorder = self._recorder(episode, stop)
        self.progress.start_episode(episode)
        try:
            run_episode(self.env, self.driver, seed, self.limit, recorder)
        except DriverError as exc:
            where = f"episode {episode} (seed {seed}): {exc}"
            problem = Problem(self.experiment.source, "driver", self.config.driver, where)
            raise ConfigError(problem) from exc
        finally:
            recorder.close()
        trace = f"episode_{episode:03d}_trace.csv"
        recorder.write_trace(self.run_dir / trace)
        result = EpisodeResult(
            episode=episode,
            seed=seed,
            episode_return=recorder.episode_return,
            steps=recorder.steps,
            tiles_visited=recorder.info.get("tiles_visited"),
            tiles_total=recorder.info.get("tiles_total"),
            laps=recorder.laps,
            obstacle_hits=recorder.obstacle_hits,
            wall_hits=recorder.info.get("walls_hit"),
            mean_abs_cte=recorder.mean_abs_cte,
            end=recorder.end,
            steps_per_second=self.progress.rate(recorder.steps),
            lap_time=recorder.lap_time,
            track=self._track_picture(seed),
            video=recorder.video.path.name if recorder.video is not None else None,
            trace=trace,
        )
        self.progress.end_episode(episode, result)
        return result

    def _recorder(self, episode: int, stop: StopSignals) -> EpisodeRecorder:
        out = self.config.output
        filmed = out.video and (out.video_episodes is None or episode < out.video_episodes)
        video = None
        if filmed:
            fps = out.fps or 1.0 / self.env.dt  # [Hz] default: real time
            video = open_video(self.run_dir / f"episode_{episode:03d}", fps)

        def on_step(recorder: EpisodeRecorder) -> None:
            self.progress.update(recorder)
            stop.check()

        return EpisodeRecorder(
            self.env.action_space,
            self.env.dt,
            video,
            self._frame,
            on_step=on_step,
            watch=lambda: route_watch(self.env),
        )

    def _frame(self, observation: Any) -> np.ndarray:
        view = self.config.output.view
        if view == "sensors":
            env = self.env
            return sensor_view(env).render(env.snapshot(), env.layout, observation)
        if view != "default":
            frame: np.ndarray = observation[view]
            return frame if frame.ndim == 3 else np.repeat(frame[..., None], 3, axis=2)  # gray
        rendered = self.env.render()  # the env was made with render_mode rgb_array
        if rendered is None:
            raise RuntimeError("the env rendered no frame for the video")
        return rendered

    def _track_picture(self, seed: int) -> str:
        key, entry = save_track_picture(self.env, seed, self.run_dir, self.tracks)
        self.tracks[key] = entry
        return key

    def _write(self, interrupted: int | None, error: str | None = None) -> None:
        from tinyrace.experiment.report import write_report

        header = {
            "experiment": self.experiment.source,
            "started": self.run_dir.name,
            "interrupted": interrupted is not None,
            "signal": None if interrupted is None else Interrupted(interrupted).args[0],
            "error": error,
            "episodes_planned": self.config.episodes,
            "track_kind": self.env.config.kind,
            "track_unit": self.env.config.facts.unit,  # u, px or m: the report's lengths
            "dt": self.env.dt,  # [s] per step
            "tracks": self.tracks,
            "config": dataclasses.asdict(self.config),
        }
        payload = write_files(self.run_dir, self.results, header)
        write_report(self.run_dir, payload, self.results)

    def _fail(self, exc: BaseException) -> None:
        """No finished episode: leave nothing behind; else keep what finished."""
        if not self.results:
            shutil.rmtree(self.run_dir, ignore_errors=True)
            if self.made_root and not any(self.run_dir.parent.iterdir()):
                self.run_dir.parent.rmdir()  # made for this run only
        else:
            self._write(None, error=one_line(exc))


def _driver(spec: str, args: dict[str, Any], source: str) -> Driver:
    """The experiment's driver; problems name the experiment file and its ``driver`` key."""
    try:
        return load_driver(spec, **args)
    except ValueError as exc:  # DriverError included: the factory raised
        raise ConfigError(Problem(source, "driver", spec, one_line(exc))) from None


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


def print_report(result: RunResult) -> None:
    """The table of episodes, the summary and where the files are, on stdout."""
    if result.interrupted is not None:
        print(f"interrupted by {Interrupted(result.interrupted).args[0]}: finished episodes only")
    print(table(result.episodes))
    print()
    print(summary_text(result.summary))
    print(f"\nresults: {result.run_dir}")
