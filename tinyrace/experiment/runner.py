"""Running an experiment end to end: episodes, driver, videos, traces, metrics, files, report.

Each episode is driven by ``tinyrace.drivers.run_episode`` (the one episode loop); an
``EpisodeRecorder`` watches it. SIGINT/SIGTERM stop the run after the current step: the
finished episodes are written, the run is marked interrupted, the open video is finished.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from tinyrace.drivers import Driver, DriverArgumentError, DriverError, load_driver, run_episode
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError, Problem, one_line
from tinyrace.experiment.interrupt import Interrupted, StopSignals
from tinyrace.experiment.load import Experiment, check_view, importable_from
from tinyrace.experiment.progress import Progress
from tinyrace.experiment.record import EpisodeRecorder
from tinyrace.experiment.results import EpisodeResult, summary, summary_text, table, write_files
from tinyrace.experiment.route import route_watch
from tinyrace.experiment.run_loop import DEFAULT_MAX_STEPS, RunLoop
from tinyrace.sensors.view import sensor_view

if TYPE_CHECKING:
    from tinyrace.experiment.race_runner import RaceRunResult


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
) -> RunResult | RaceRunResult:
    """Run every episode; write results.json, episodes.csv, traces, videos and report.html
    into a new run folder under ``out_root`` (default: ``output.dir``, relative to the cwd).
    A race (several cars) is run by ``race_runner.run_race``: a driver per car, a row per car.

    Raises ConfigError for a bad view or driver (no run folder is left behind when no
    episode finished).
    """
    if experiment.is_race:  # imported here: races need PettingZoo, one car does not
        from tinyrace.experiment.race_runner import run_race

        return run_race(experiment, out_root, show_progress, progress)
    config = experiment.config
    render_mode = "rgb_array" if config.output.video and config.output.view == "default" else None
    env = TinyRaceEnv(config=experiment.loaded, render_mode=render_mode)
    try:
        check_view(experiment.config, env.config, experiment.source)
        with importable_from(experiment.folder):  # own drivers sit beside the experiment file
            driver = _driver(config.driver, config.driver_args, experiment.source)
        progress = progress or Progress(
            config.episodes, enabled=show_progress, video=config.output.video
        )
        run = _Run(experiment, env, driver, out_root, progress)
        return RunResult(run.run_dir, run.results, run.all())
    finally:
        env.close()


class _Run(RunLoop[EpisodeResult]):
    """One car's run: its driver, its env."""

    def __init__(
        self,
        experiment: Experiment,
        env: TinyRaceEnv,
        driver: Driver,
        out_root: Path | None,
        progress: Progress,
    ):
        config = experiment.config
        limit = config.max_steps or env.config.sim.step_limit or DEFAULT_MAX_STEPS
        super().__init__(experiment, out_root, progress, limit)
        self.env, self.driver = env, driver
        self._insets: tuple[list[str], list[tuple[int, ...]]] | None = None  # names, sizes

    def _episode(self, episode: int, stop: StopSignals) -> EpisodeResult:
        seed = self.config.seed + episode
        recorder = self._recorder(episode, stop)
        self.progress.start_episode(episode)
        try:
            run_episode(self.env, self.driver, seed, self.limit, recorder)
            simulated = self.progress.rate(recorder.steps, recorder.film_seconds)
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
            steps_per_second=simulated,
            lap_time=recorder.lap_time,
            track=self.track_picture(self.env, seed),
            video=recorder.video.path.name if recorder.video is not None else None,
            trace=trace,
            wall_seconds=self.progress.elapsed(),
        )
        self.progress.end_episode(episode, result)
        return result

    def _recorder(self, episode: int, stop: StopSignals) -> EpisodeRecorder:
        video = self.episode_video(episode, self.env.dt)

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
        named: np.ndarray = rendered.copy()
        if self._insets is None:  # the same cameras all run long
            self._insets = _inset_cameras(self.env)
        self.env.pictures.name_insets(named, *self._insets)  # who is who
        return named

    def _write(self, interrupted: int | None, error: str | None = None) -> None:
        from tinyrace.experiment.report import write_report

        header = self.header(self.env, interrupted, error)
        payload = write_files(self.run_dir, self.results, header)
        write_report(self.run_dir, payload, self.results)


def _inset_cameras(env: TinyRaceEnv) -> tuple[list[str], list[tuple[int, ...]]]:
    """The ids and image sizes of the cameras an overview insets (the sensors with a
    top-down picture), in order."""
    snapshot = env.snapshot()
    views = [s for s in env.sensors if s.top_down(snapshot, env.layout) is not None]
    sizes = [tuple(s.space.shape or ())[:2] for s in views]
    return [s.id for s in views], sizes


def _driver(spec: str, args: dict[str, Any], source: str) -> Driver:
    """The experiment's driver; problems name the experiment file and its ``driver`` key."""
    try:
        return load_driver(spec, **args)
    except DriverArgumentError as exc:
        raise ConfigError(
            Problem(source, f"driver_args.{exc.name}", exc.value, exc.allowed)
        ) from None
    except ValueError as exc:  # DriverError included: the factory raised
        raise ConfigError(Problem(source, "driver", spec, one_line(exc))) from None


def print_report(result: RunResult | RaceRunResult) -> None:
    """The table of episodes (of cars, in a race), the summary and where the files are, on
    stdout."""
    if result.interrupted is not None:
        print(f"interrupted by {Interrupted(result.interrupted).args[0]}: finished episodes only")
    if not isinstance(result, RunResult):
        from tinyrace.experiment import race_results

        print(race_results.car_table(race_results.car_rows(result.episodes)))
        print()
        print(race_results.summary_text(result.summary))
    else:
        print(table(result.episodes))
        print()
        print(summary_text(result.summary))
    print(f"\nresults: {result.run_dir}")
