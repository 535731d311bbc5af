"""Running a race end to end: one driver per car, one video with every car, a trace and a
row of results per car, the files and the report.

The race is a ``RaceEnv`` (PettingZoo) of the experiment's env, driven by
``race.drive.drive_race``; a ``RaceRecorder`` (``race_record.py``) watches it: a
``CarRecorder`` per car (its trace, laps, contacts), the standings after every step, the
video.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

from tinyrace.config import car_colors
from tinyrace.drivers import Driver, DriverArgumentError, load_driver
from tinyrace.errors import ConfigError, Problem, one_line
from tinyrace.experiment.interrupt import StopSignals
from tinyrace.experiment.load import Experiment, importable_from
from tinyrace.experiment.progress import Progress
from tinyrace.experiment.race_drivers import CarDriver, car_drivers
from tinyrace.experiment.race_record import CarRecorder, RaceRecorder
from tinyrace.experiment.race_results import (
    CarResult,
    RaceEpisode,
    car_rows,
    car_summary,
    write_race_files,
)
from tinyrace.experiment.run_loop import DEFAULT_MAX_STEPS, RunLoop
from tinyrace.race import RaceEnv
from tinyrace.race.drive import CarDriverError, drive_race


@dataclass
class RaceRunResult:
    """The run folder, the finished races, and the signal that stopped the run (if any)."""

    run_dir: Path
    episodes: list[RaceEpisode]
    interrupted: int | None = None  # signal number

    @property
    def summary(self) -> dict[str, dict[str, dict[str, float]]]:
        """Per car: each metric's mean and std over the episodes, and its wins."""
        return car_summary(car_rows(self.episodes))


def file_part(agent: str) -> str:
    """A car's name as part of a file name, one to one: a name of lowercase letters, digits,
    '_', '.' and '-' (up to 40 characters) is itself; any other is those characters of it
    (others '_', at most 24), '+' and 12 hex digits of its sha256, so two names never share a
    file, even on a file system that ignores case."""
    if _PLAIN.fullmatch(agent):
        return agent
    kept = re.sub(r"[^a-z0-9_.-]", "_", agent.lower())[:24]
    return f"{kept}+{hashlib.sha256(agent.encode()).hexdigest()[:12]}"


_PLAIN = re.compile(r"[a-z0-9_.-]{1,40}")


class RaceRun(RunLoop[RaceEpisode]):
    """A race's run: its env, a driver per car."""

    def __init__(
        self,
        experiment: Experiment,
        race: RaceEnv,
        drivers: dict[str, tuple[CarDriver, Driver]],
        out_root: Path | None,
        progress: Progress,
    ):
        config = experiment.config
        limit = config.max_steps or race.core.config.sim.step_limit or DEFAULT_MAX_STEPS
        super().__init__(experiment, out_root, progress, limit)
        self.race = race
        self.specs = {agent: spec for agent, (spec, _) in drivers.items()}
        self.drivers = {agent: driver for agent, (_, driver) in drivers.items()}

    def _episode(self, episode: int, stop: StopSignals) -> RaceEpisode:
        seed = self.config.seed + episode
        recorder = self._recorder(episode, stop)
        self.progress.start_episode(episode)
        try:
            drive_race(self.race, self.drivers, seed, self.limit, recorder)
        except CarDriverError as exc:
            spec = self.specs[exc.agent]
            where = f"car {exc.agent}'s driver, episode {episode} (seed {seed}): {exc}"
            raise ConfigError(Problem(self.experiment.source, spec.key, spec.spec, where)) from exc
        finally:
            recorder.close()
        track = self.track_picture(self.race.core, seed)
        video = recorder.video.path.name if recorder.video is not None else None
        order = recorder.order()
        cars = []
        for agent, car in recorder.cars.items():
            trace = f"episode_{episode:03d}_{file_part(agent)}_trace.csv"
            car.write_trace(self.run_dir / trace)
            cars.append(self._car_result(episode, seed, agent, car, order, track, video, trace))
        rate = self.progress.rate(recorder.steps, recorder.film_seconds)  # video left out
        result = RaceEpisode(episode, seed, recorder.steps, order, cars, rate, track, video)
        self._end_line(result)
        return result

    def _car_result(
        self,
        episode: int,
        seed: int,
        agent: str,
        car: CarRecorder,
        order: list[str],
        track: str,
        video: str | None,
        trace: str,
    ) -> CarResult:
        info = car.info
        return CarResult(
            episode=episode,
            seed=seed,
            car=agent,
            position=order.index(agent) + 1,
            episode_return=car.episode_return,
            steps=car.steps,
            laps=car.laps,
            lap_times=car.lap_times,
            best_lap=car.best_lap,
            tiles_visited=info.get("tiles_visited"),
            tiles_total=info.get("tiles_total"),
            cars_hit=car.cars_hit,
            cars_touched=list(car.touched),
            wall_hits=info.get("walls_hit"),
            cones_hit=info.get("cones_hit"),
            obstacle_hits=car.obstacle_hits,
            mean_abs_cte=car.mean_abs_cte,
            end=car.end,
            driver=self.specs[agent].spec,
            track=track,
            video=video,
            trace=trace,
        )

    def _recorder(self, episode: int, stop: StopSignals) -> RaceRecorder:
        video = self.episode_video(episode, self.race.core.dt)

        def on_step(recorder: RaceRecorder) -> None:
            self.progress.update(recorder.leader)
            stop.check()

        return RaceRecorder(self.race, video, on_step)

    def _end_line(self, result: RaceEpisode) -> None:
        """The episode's line: the cars in their final order, with their best laps."""
        progress = self.progress
        progress.close()
        if not progress.enabled:
            return
        by_car = {car.car: car for car in result.cars}
        places = []
        for agent in result.order:
            car = by_car[agent]
            lap = f" {car.best_lap:.2f} s" if car.best_lap is not None else ""
            places.append(f"{car.position}. {agent}{lap} ({car.end})")
        line = f"{progress.name(result.episode)}: {', '.join(places)}\n"
        progress.stream.write(line)
        progress.stream.flush()

    def _write(self, interrupted: int | None, error: str | None = None) -> None:
        from tinyrace.experiment.race_report import write_race_report

        core = self.race.core
        colors = car_colors(core.config)
        cars = [
            {"id": agent, "color": repr(colors[i % len(colors)]), "driver": self.specs[agent].spec}
            for i, agent in enumerate(self.race.possible_agents)
        ]
        header = {**self.header(core, interrupted, error), "cars": cars}
        payload = write_race_files(self.run_dir, self.results, header)
        write_race_report(self.run_dir, payload, car_rows(self.results))


def _load(driver: CarDriver, source: str) -> Driver:
    """A car's driver; problems name the experiment file, its key and the car."""
    try:
        return load_driver(driver.spec, **driver.args)
    except DriverArgumentError as exc:
        where = "driver_args" if driver.key == "driver" else f"{driver.key}.driver_args"
        allowed = f"car {driver.agent}'s driver: {exc.allowed}"
        raise ConfigError(Problem(source, f"{where}.{exc.name}", exc.value, allowed)) from None
    except ValueError as exc:  # DriverError included: the factory raised
        allowed = f"car {driver.agent}'s driver: {one_line(exc)}"
        raise ConfigError(Problem(source, driver.key, driver.spec, allowed)) from None


def run_race(
    experiment: Experiment,
    out_root: Path | None = None,
    show_progress: bool = True,
    progress: Progress | None = None,
) -> RaceRunResult:
    """Run every episode of a race (``experiment.is_race``); write results.json,
    episodes.csv (a row per car), each car's trace, a video per episode and report.html into
    a new run folder under ``out_root`` (default: ``output.dir``, relative to the cwd).

    Raises ConfigError for a bad driver (naming its car); no run folder is left behind
    when no episode finished.
    """
    config = experiment.config
    render_mode = "rgb_array" if config.output.video else None
    loaded = cast(Any, experiment.loaded)  # a LoadedConfig, as TinyRaceEnv takes it
    race = RaceEnv(config=loaded, render_mode=render_mode)
    try:
        specs, problems = car_drivers(config, race.possible_agents, experiment.source)
        if problems:
            raise ConfigError(problems)
        with importable_from(experiment.folder):  # own drivers sit beside the experiment file
            drivers = {d.agent: (d, _load(d, experiment.source)) for d in specs}
        progress = progress or Progress(
            config.episodes, enabled=show_progress, video=config.output.video
        )
        run = RaceRun(experiment, race, drivers, out_root, progress)
        return RaceRunResult(run.run_dir, run.results, run.all())
    finally:
        race.close()
