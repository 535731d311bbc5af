"""Running a race end to end: one driver per car, one video with every car, a trace and a
row of results per car, the files and the report.

The race is a ``RaceEnv`` (PettingZoo) of the experiment's env, driven by
``race.drive.drive_race``; a ``RaceRecorder`` watches it: a ``CarRecorder`` per car (its
trace, laps, contacts), the standings after every step, the video. A car's place is
decided by its laps, then (between cars with as many laps) by the earlier finish of its
last one, then by how far round the track's line it is (tiles visited on a track without
one), then by who got that far first, then by its place on the grid.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

from gymnasium import spaces

from tinyrace.config import car_colors
from tinyrace.drivers import Driver, load_driver
from tinyrace.errors import ConfigError, Problem, one_line
from tinyrace.experiment.interrupt import StopSignals
from tinyrace.experiment.load import Experiment, importable_from
from tinyrace.experiment.progress import Progress
from tinyrace.experiment.race_drivers import CarDriver, car_drivers
from tinyrace.experiment.race_results import (
    RACE_TRACE_COLUMNS,
    CarResult,
    RaceEpisode,
    car_rows,
    car_summary,
    write_race_files,
)
from tinyrace.experiment.record import EpisodeRecorder
from tinyrace.experiment.route import RouteWatch, route_watch
from tinyrace.experiment.run_loop import DEFAULT_MAX_STEPS, RunLoop, new_run_dir
from tinyrace.experiment.video import VideoWriter, open_video
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


class CarRecorder(EpisodeRecorder):
    """One car's recorder in a race: its trace (with its place and the cars it touched), its
    laps and lap times, its contacts with other cars."""

    def __init__(self, space: spaces.Space[Any], dt: float, watch: Callable[[], Any]):
        super().__init__(space, dt, watch=watch)
        self.extras: list[tuple[int, str]] = []  # (position, cars touched) per trace row
        self.cars_hit = 0
        self.touched: dict[str, None] = {}  # in the order first touched
        self._best = 0.0  # the most progress so far
        self.reached = 0  # the step it got there: of two cars as far on, the first is ahead

    def step(
        self,
        action: Any,
        observation: Any,
        reward: float,
        terminated: bool,
        truncated: bool,
        info: dict[str, Any],
    ) -> None:
        super().step(action, observation, reward, terminated, truncated, info)
        self._follow(info)
        laps = info.get("laps")
        if isinstance(laps, int) and not isinstance(laps, bool):  # the env counts laps
            self._lap_done(laps)
        if self.progress > self._best:
            self._best, self.reached = self.progress, self.steps
        hit = [str(car) for car in info.get("cars_hit") or ()]
        self.cars_hit += len(hit)
        self.touched.update(dict.fromkeys(hit))

    def start(self, observation: Any, info: dict[str, Any]) -> None:
        super().start(observation, info)
        self._follow(info)

    def _follow(self, info: dict[str, Any]) -> None:
        """Where the car is along the track's line (the route watch follows it)."""
        x, y, _ = info.get("pose", (math.nan, math.nan, math.nan))
        if self.route is not None and math.isfinite(x) and math.isfinite(y):
            self.route.laps(x, y)

    @property
    def lap_times(self) -> list[float]:
        """[s] each finished lap's time: the env's ``lap_times`` where it gives them, else
        from the steps that finished them."""
        given = self.info.get("lap_times")
        if isinstance(given, (list, tuple)) and all(_number(t) for t in given):
            return [float(t) for t in given]
        ends = self.lap_steps
        starts = [0, *ends][: len(ends)]
        return [round((end - start) * self.dt, 9) for start, end in zip(starts, ends, strict=True)]

    @property
    def best_lap(self) -> float | None:
        """[s] the env's ``best_lap`` where it gives one, else the fastest lap time."""
        given = self.info.get("best_lap")
        if isinstance(given, (int, float)) and not isinstance(given, bool):
            return float(given)
        times = self.lap_times
        return min(times) if times else None

    def standing(self, index: int) -> tuple[float, ...]:
        """The sort key of the car's place (smaller is ahead); ``index``: its grid slot."""
        finished = self.lap_steps[-1] if self.lap_steps else 0
        return (-self.laps, finished, -self.progress, self.reached, index)

    @property
    def progress(self) -> float:
        """How far round the track the car is: [route points] along the track's line from
        the start line, else (a track without a closed line) the tiles it visited."""
        route: RouteWatch | None = self.route
        if route is not None and route.closed:
            return float(route.along)
        return float(self.info.get("tiles_visited") or 0)

    def write_trace(self, path: Path) -> None:
        with path.open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(RACE_TRACE_COLUMNS)
            for row, extra in zip(self.rows, self.extras, strict=True):
                cells = (round(v, 6) if isinstance(v, float) else v for v in row)
                writer.writerow((*cells, *extra))


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class RaceRecorder:
    """A ``RaceObserver``: each car's recorder, the standings, the episode's video."""

    def __init__(
        self,
        race: RaceEnv,
        video: VideoWriter | None,
        on_step: Callable[[RaceRecorder], None] | None = None,
    ):
        self.race = race
        self.video = video
        self.on_step = on_step
        core = race.core
        watch: Callable[[], Any] = lambda: route_watch(core)  # noqa: E731
        self.cars = {
            agent: CarRecorder(race.action_space(agent), core.dt, watch)
            for agent in race.possible_agents
        }
        self.steps = 0

    def start(self, observations: dict[str, Any], infos: dict[str, Any]) -> None:
        for agent, recorder in self.cars.items():
            recorder.start(observations[agent], infos[agent])
        self._after(infos)

    def step(
        self,
        actions: dict[str, Any],
        observations: dict[str, Any],
        rewards: dict[str, float],
        terminations: dict[str, bool],
        truncations: dict[str, bool],
        infos: dict[str, Any],
    ) -> None:
        self.steps += 1
        for agent, info in infos.items():
            self.cars[agent].step(
                actions[agent],
                observations[agent],
                float(rewards[agent]),
                terminations[agent],
                truncations[agent],
                info,
            )
        self._after(infos)
        if self.on_step is not None:
            self.on_step(self)

    def _after(self, infos: dict[str, Any]) -> None:
        """Each racing car's place and contacts into its trace; the frame into the video."""
        order = self.order()
        for agent, info in infos.items():
            hit = " ".join(str(car) for car in info.get("cars_hit") or ())
            self.cars[agent].extras.append((order.index(agent) + 1, hit))
        if self.video is not None:
            frame = self.race.render()  # the race was made with render_mode rgb_array
            if frame is None:
                raise RuntimeError("the race rendered no frame for the video")
            self.video.write(frame)

    def order(self) -> list[str]:
        """The cars by place, leader first."""
        slots = {agent: i for i, agent in enumerate(self.cars)}
        return sorted(self.cars, key=lambda agent: self.cars[agent].standing(slots[agent]))

    @property
    def leader(self) -> CarRecorder:
        """The leading car still racing (else the leader): what the progress bar shows."""
        racing = [agent for agent in self.order() if agent in self.race.agents]
        return self.cars[(racing or self.order())[0]]

    def close(self) -> None:
        """Finish the video (also after an interruption: the file still plays)."""
        if self.video is not None:
            self.video.close()


def file_part(agent: str) -> str:
    """A car's name as part of a file name."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", agent)[:64]


class RaceRun(RunLoop[RaceEpisode]):
    """A race's run: its env, a driver per car."""

    def __init__(
        self,
        experiment: Experiment,
        race: RaceEnv,
        drivers: dict[str, tuple[CarDriver, Driver]],
        run_dir: Path,
        progress: Progress,
    ):
        config = experiment.config
        limit = config.max_steps or race.core.config.sim.step_limit or DEFAULT_MAX_STEPS
        super().__init__(experiment, run_dir, progress, limit)
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
        rate = self.progress.rate(recorder.steps)
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
        out = self.config.output
        filmed = out.video and (out.video_episodes is None or episode < out.video_episodes)
        video = None
        if filmed:
            fps = out.fps or 1.0 / self.race.core.dt  # [Hz] default: real time
            video = open_video(self.run_dir / f"episode_{episode:03d}", fps)

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
        line = f"episode {result.episode + 1}/{self.config.episodes}: {', '.join(places)}\n"
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
        progress = progress or Progress(config.episodes, enabled=show_progress)
        root = Path(out_root or config.output.dir)
        made_root = not root.exists()
        run = RaceRun(experiment, race, drivers, new_run_dir(root, experiment.name), progress)
        run.made_root = made_root
        return RaceRunResult(run.run_dir, run.results, run.all())
    finally:
        race.close()
